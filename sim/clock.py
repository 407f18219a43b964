"""The onboard clock: a DSAC-class three-state random process (phase, frequency, drift).

State x = [b, f, a]: phase error b [s] (clock reading minus TDB), fractional frequency error
f [1] and fractional frequency drift a [1/s]. Continuous-time model (the standard three-state
clock model, e.g. Zucca & Tavella 2005, IEEE UFFC 52(2)):

    db/dt = f + w1,   df/dt = a + w2,   da/dt = w3,

with independent white noises of two-sided spectral densities q1 [s] (white FM), q2 [1/s]
(random-walk FM) and q3 [1/s^3] (random-run FM: the drift wanders).

**Allan variance of this model.** Each noise contributes independently:

    sigma_y^2(tau) = q1 / tau  +  q2 tau / 3  +  q3 tau^3 / 20   (+ a^2 tau^2 / 2 for a
    deterministic drift a).

**Default parameters (DSAC-class, DESIGN.md: ~2e-15 at 1 day, drift ~3e-16/day).** With
tau_d = 86400 s, white FM carries 1.6e-15 of the 2e-15 at one day and random-walk FM the rest:

    q1 = (1.6e-15)^2 tau_d                    = 2.2118e-25 s      (4.7e-13 at 1 s)
    q2 = 3 ((2.0e-15)^2 - (1.6e-15)^2) / tau_d = 5.0000e-35 1/s   (3.8e-15 at 10 days)
    q3 = 1e-50 1/s^3  (the drift wanders by ~1.7e-17/day over 45 days; adds 6e-19 at 1 day).

The mean drift 3e-16/day adds a tau / sqrt(2) = 2.1e-16 at one day in quadrature (2.01e-15 in
all); an Allan deviation is normally quoted with the drift removed.

**Discretisation.** Over a step h the transition is Phi = [[1, h, h^2/2], [0, 1, h], [0, 0, 1]]
and the exact process-noise covariance Q_d = int_0^h Phi(s) diag(q1, q2, q3) Phi(s)^T ds is

    Q11 = q1 h + q2 h^3/3 + q3 h^5/20   Q12 = q2 h^2/2 + q3 h^4/8   Q13 = q3 h^3/6
    Q22 = q2 h + q3 h^3/3               Q23 = q3 h^2/2              Q33 = q3 h.

**Truth between nodes.** The realisation is stored at nodes every ``node_step_s``; between two
nodes, phase is the quintic Hermite polynomial matching (b, f, a) at both ends, frequency its
first derivative and drift its second. The three queried states are therefore mutually
consistent (frequency is exactly the rate of the returned phase), continuous, and equal to the
sampled process at the nodes. (The white-FM phase wander inside one node step, sqrt(q1 h), is
2 ps at 60 s — far below the measurement noise.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY
from fsw.interface.typed import spec

_TAU_DAY = SECONDS_PER_DAY
DEFAULT_Q1 = (1.6e-15) ** 2 * _TAU_DAY
DEFAULT_Q2 = 3.0 * ((2.0e-15) ** 2 - (1.6e-15) ** 2) / _TAU_DAY
DEFAULT_Q3 = 1.0e-50


class ClockError(ValueError):
    """Bad clock input: a query outside the realised span, non-finite times, bad steps."""


@dataclass(frozen=True, slots=True)
class ClockConfig:
    """Onboard (DSAC-class) clock: three-state random process and its initial dispersion."""

    q_white_fm_s: float = spec(DEFAULT_Q1, doc="white-FM spectral density q1 (sigma_y^2 = q1/tau)", unit="s", ge=0.0)
    q_random_walk_fm_per_s: float = spec(
        DEFAULT_Q2, doc="random-walk-FM spectral density q2 (sigma_y^2 = q2 tau/3)", unit="1/s", ge=0.0
    )
    q_random_run_per_s3: float = spec(
        DEFAULT_Q3, doc="random-run spectral density q3 of the drift (sigma_y^2 = q3 tau^3/20)", unit="1/s^3", ge=0.0
    )
    phase0_s: float = spec(0.0, doc="mean initial phase error (clock minus TDB)", unit="s")
    phase0_sigma_s: float = spec(
        1.0e-7, doc="1-sigma initial phase error after the last ground synchronisation (30 m of range)", unit="s", ge=0.0
    )
    frequency0: float = spec(0.0, doc="mean initial fractional frequency error", unit="1")
    frequency0_sigma: float = spec(
        1.0e-13, doc="1-sigma initial fractional frequency error (0.03 mm/s of one-way range rate)", unit="1", ge=0.0
    )
    drift_per_day: float = spec(3.0e-16, doc="mean fractional frequency drift (DSAC-class)", unit="1/day")
    drift_sigma_per_day: float = spec(1.0e-16, doc="1-sigma of the initial drift about its mean", unit="1/day", ge=0.0)
    node_step_s: float = spec(60.0, doc="spacing of the stored realisation nodes", unit="s", gt=0.0, le=86400.0)


def transition(h: float) -> np.ndarray:
    """State transition Phi(h) of the three-state clock model."""
    return np.array([[1.0, h, 0.5 * h * h], [0.0, 1.0, h], [0.0, 0.0, 1.0]])


def process_noise(h: float, q1: float, q2: float, q3: float) -> np.ndarray:
    """Exact discrete process-noise covariance Q_d(h) of the three-state clock model."""
    h2, h3, h4, h5 = h * h, h**3, h**4, h**5
    return np.array(
        [
            [q1 * h + q2 * h3 / 3.0 + q3 * h5 / 20.0, q2 * h2 / 2.0 + q3 * h4 / 8.0, q3 * h3 / 6.0],
            [q2 * h2 / 2.0 + q3 * h4 / 8.0, q2 * h + q3 * h3 / 3.0, q3 * h2 / 2.0],
            [q3 * h3 / 6.0, q3 * h2 / 2.0, q3 * h],
        ]
    )


def allan_variance_model(tau, q1: float, q2: float, q3: float, drift: float = 0.0):
    """sigma_y^2(tau) of the model (see the module docstring); ``drift`` in 1/s."""
    tau = np.asarray(tau, dtype=float)
    return q1 / tau + q2 * tau / 3.0 + q3 * tau**3 / 20.0 + 0.5 * (drift * tau) ** 2


def _psd_sqrt(cov: np.ndarray) -> np.ndarray:
    """A square root L (cov = L L^T) that works for badly scaled or singular PSD matrices."""
    d = np.sqrt(np.diag(cov))
    scale = np.where(d > 0.0, d, 1.0)
    corr = cov / np.outer(scale, scale)
    w, v = np.linalg.eigh(corr)
    return scale[:, None] * (v * np.sqrt(np.clip(w, 0.0, None)))


@dataclass(frozen=True, slots=True)
class ClockStep:
    """A misbehaviour of the clock itself: from ``t_on`` (until ``t_off``) its phase is offset by
    ``phase_s + frequency (t - t_on)`` and its frequency by ``frequency``."""

    t_on: float
    t_off: float | None
    phase_s: float
    frequency: float


class ClockTruth:
    """One realisation of the onboard clock, queryable at any TDB time inside its span.

    ``state(t)`` -> (phase [s], frequency [1], drift [1/s]) arrays (the quintic Hermite
    interpolation described in the module docstring) plus any :class:`ClockStep` in force.
    ``reading(t) = t + phase(t)`` is what the onboard clock shows at true TDB ``t``.
    """

    def __init__(self, t_nodes: np.ndarray, nodes: np.ndarray, steps: tuple[ClockStep, ...] = ()) -> None:
        t_nodes = np.asarray(t_nodes, dtype=float)
        nodes = np.asarray(nodes, dtype=float)
        if t_nodes.ndim != 1 or t_nodes.size < 2 or nodes.shape != (t_nodes.size, 3):
            raise ClockError("need >= 2 node times and a (n, 3) array of [phase, frequency, drift]")
        if not (np.all(np.isfinite(t_nodes)) and np.all(np.isfinite(nodes))):
            raise ClockError("clock nodes must be finite")
        h = np.diff(t_nodes)
        if np.any(h <= 0.0) or not np.allclose(h, h[0], rtol=1e-9, atol=0.0):
            raise ClockError("clock nodes must be uniformly spaced and increasing")
        self.t_nodes = t_nodes
        self.nodes = nodes
        self.step_s = float(h[0])
        self.steps = tuple(steps)

    @property
    def t_start(self) -> float:
        return float(self.t_nodes[0])

    @property
    def t_end(self) -> float:
        return float(self.t_nodes[-1])

    def with_steps(self, steps: tuple[ClockStep, ...]) -> "ClockTruth":
        """The same realisation with clock misbehaviours added (the noise is untouched)."""
        for s in steps:
            if not np.isfinite(s.t_on) or (s.t_off is not None and not s.t_off > s.t_on):
                raise ClockError(f"bad clock step window [{s.t_on}, {s.t_off})")
        return ClockTruth(self.t_nodes, self.nodes, self.steps + tuple(steps))

    @overload
    def state(self, t_tdb: float) -> tuple[float, float, float]: ...

    @overload
    def state(self, t_tdb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def state(self, t_tdb: float | np.ndarray) -> tuple[float, float, float] | tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(phase [s], fractional frequency [1], drift [1/s]) at TDB ``t_tdb`` (scalar or array)."""
        t = np.asarray(t_tdb, dtype=float)
        scalar = t.ndim == 0
        t = np.atleast_1d(t)
        if not np.all(np.isfinite(t)):
            raise ClockError("clock query time is not finite")
        if t.size and (t.min() < self.t_start or t.max() > self.t_end):
            raise ClockError(f"clock queried outside its realised span [{self.t_start:.1f}, {self.t_end:.1f}] s")
        h = self.step_s
        x = (t - self.t_start) / h
        i = np.clip(np.floor(x).astype(np.int64), 0, self.t_nodes.size - 2)
        s = x - i
        b0, f0, a0 = self.nodes[i, 0], self.nodes[i, 1] * h, self.nodes[i, 2] * h * h
        b1, f1, a1 = self.nodes[i + 1, 0], self.nodes[i + 1, 1] * h, self.nodes[i + 1, 2] * h * h
        s2 = s * s
        s3 = s2 * s
        s4 = s3 * s
        s5 = s4 * s
        # Quintic Hermite basis: values, first and second derivatives matched at both ends.
        phase = (
            (1 - 10 * s3 + 15 * s4 - 6 * s5) * b0
            + (s - 6 * s3 + 8 * s4 - 3 * s5) * f0
            + (0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5) * a0
            + (0.5 * s3 - s4 + 0.5 * s5) * a1
            + (-4 * s3 + 7 * s4 - 3 * s5) * f1
            + (10 * s3 - 15 * s4 + 6 * s5) * b1
        )
        dphase = (
            (-30 * s2 + 60 * s3 - 30 * s4) * b0
            + (1 - 18 * s2 + 32 * s3 - 15 * s4) * f0
            + (s - 4.5 * s2 + 6 * s3 - 2.5 * s4) * a0
            + (1.5 * s2 - 4 * s3 + 2.5 * s4) * a1
            + (-12 * s2 + 28 * s3 - 15 * s4) * f1
            + (30 * s2 - 60 * s3 + 30 * s4) * b1
        ) / h
        ddphase = (
            (-60 * s + 180 * s2 - 120 * s3) * b0
            + (-36 * s + 96 * s2 - 60 * s3) * f0
            + (1 - 9 * s + 18 * s2 - 10 * s3) * a0
            + (3 * s - 12 * s2 + 10 * s3) * a1
            + (-24 * s + 84 * s2 - 60 * s3) * f1
            + (60 * s - 180 * s2 + 120 * s3) * b1
        ) / (h * h)
        for step in self.steps:
            on = t >= step.t_on
            if step.t_off is not None:
                on &= t < step.t_off
            phase = phase + np.where(on, step.phase_s + step.frequency * (t - step.t_on), 0.0)
            dphase = dphase + np.where(on, step.frequency, 0.0)
        if scalar:
            return float(phase[0]), float(dphase[0]), float(ddphase[0])
        return phase, dphase, ddphase

    def phase(self, t_tdb):
        """Phase error [s] (clock reading minus TDB) at TDB ``t_tdb``."""
        return self.state(t_tdb)[0]

    def reading(self, t_tdb):
        """What the onboard clock reads at true TDB ``t_tdb`` [s past J2000]."""
        return np.asarray(t_tdb, dtype=float) + self.phase(t_tdb) if np.ndim(t_tdb) else float(t_tdb) + self.phase(t_tdb)


def simulate_clock(cfg: ClockConfig, t_start: float, t_end: float, rng: np.random.Generator) -> ClockTruth:
    """Draw one clock realisation on nodes every ``cfg.node_step_s`` covering [t_start, t_end].

    The initial state is drawn from the configured dispersion, then x_{k+1} = Phi x_k + w_k with
    w_k ~ N(0, Q_d) (exact discretisation). The recursion is written as cumulative sums, which
    is the same recursion without a Python loop over the nodes.
    """
    if not (np.isfinite(t_start) and np.isfinite(t_end) and t_end > t_start):
        raise ClockError("clock span must be finite with t_end > t_start")
    h = cfg.node_step_s
    n = int(np.ceil((t_end - t_start) / h)) + 1
    t_nodes = t_start + h * np.arange(n)
    per_day = 1.0 / SECONDS_PER_DAY
    z0 = rng.standard_normal(3)
    b0 = cfg.phase0_s + cfg.phase0_sigma_s * z0[0]
    f0 = cfg.frequency0 + cfg.frequency0_sigma * z0[1]
    a0 = (cfg.drift_per_day + cfg.drift_sigma_per_day * z0[2]) * per_day
    L = _psd_sqrt(process_noise(h, cfg.q_white_fm_s, cfg.q_random_walk_fm_per_s, cfg.q_random_run_per_s3))
    w = rng.standard_normal((n - 1, 3)) @ L.T
    a = a0 + np.concatenate(([0.0], np.cumsum(w[:, 2])))
    f = f0 + np.concatenate(([0.0], np.cumsum(h * a[:-1] + w[:, 1])))
    b = b0 + np.concatenate(([0.0], np.cumsum(h * f[:-1] + 0.5 * h * h * a[:-1] + w[:, 0])))
    return ClockTruth(t_nodes, np.column_stack((b, f, a)))

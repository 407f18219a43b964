"""State-residual adaptive process noise (Garhwal, Halder & Sinha): Q from the state residuals and
their slopes, the slope fitted over a moving window by Tanaka's possibilistic fuzzy linear
regression (``fuzzy-adaptive``) or by least squares (``lsq-adaptive``).

The state residual Δx̄ of an update is the state correction it applies, x⁺ − x⁻ = K ν. Each state's
last λ residuals (a bounded ring buffer) are fitted with a straight line against time; its slope is
Δẋ̄ and Q = |Δx̄ · Δẋ̄| δ_ij (eq. 1). Until the window holds ``warmup`` residuals the filter keeps its
plain process noise.

The paper solves the FLR linear program with its own big-M simplex; here HiGHS solves it
(:func:`scipy.optimize.linprog`). The paper's "big M" survives as what it does there — a per-state
bound M on the fuzzy coefficients (|p₀|, c₀ ≤ M and |p₁|, c₁ ≤ M / span of the window) — so a
window the LP cannot fit within the bound is a counted, infeasible outcome rather than an
arbitrarily large Q.

Cost: the fits run inside the update, i.e. inside the bank's executive stage, so in CPU budget mode
their measured time is charged with it; in work-unit mode the stage's declared cost grows by
``lp_cost`` per LP (:meth:`AdaptiveQ.declared_cost`, added through the pipeline's ``Load``). The LP
count, failures, fallbacks and total LP CPU time go out in every FSW ``RunStatus`` (``adaptive_*``
counters) when a filter is adaptive.

Bad LP outcomes (infeasible, unbounded, solver failure, a degenerate window whose times do not
span an interval) are counted; the fallback is the least-squares slope, and where that too is
undefined (all times equal) the state's previous Q.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from fsw.interface.typed import spec

ProcessNoiseMode = Literal["fixed", "fuzzy-adaptive", "lsq-adaptive"]


def linprog_solver() -> Any:
    """:func:`scipy.optimize.linprog`, imported on demand: the configuration imports this module in
    every process and scipy.optimize costs 0.1-0.3 s of a start. The FSW core asks for it while
    it is built when a filter adapts its process noise, not in the frame of the first LP."""
    from scipy.optimize import linprog

    return linprog


@dataclass(frozen=True, slots=True)
class AdaptiveQConfig:
    """Process noise of one EKF: fixed (the configured models only) or adaptive per eq. 1 of
    Garhwal, Halder & Sinha, added on the position and velocity states (the six state residuals
    of the paper)."""

    mode: ProcessNoiseMode = spec("fixed", doc="fixed | fuzzy-adaptive (Tanaka FLR slope) | lsq-adaptive (least-squares slope)")
    window: int = spec(10, doc="moving window λ of state residuals the slope is fitted over", ge=2, le=200)
    h: float = spec(0.0, doc="FLR confidence level h of the inclusion constraints (eqs. 11-12)", unit="1", ge=0.0, lt=1.0)
    big_m: tuple[float, ...] | None = spec(
        None, doc="per-state bound M on the FLR coefficients [x, y, z, vx, vy, vz] (km, km/s); null: unbounded",
        shape=(6,),
    )
    warmup: int = spec(10, doc="residuals collected before the adaptive Q is applied (plain Q until then)", ge=2)
    lp_cost: float = spec(
        45.0, doc="declared work-unit cost of one FLR linear program (budget mode work-units; six per update of a "
        "fuzzy-adaptive filter): ~0.9 ms of host CPU at ~20 us per work unit", unit="work unit", ge=0.0,
    )

    def __post_init__(self) -> None:
        if self.warmup > self.window:
            raise ValueError(f"warmup ({self.warmup}) cannot exceed the window ({self.window})")
        if self.big_m is not None and not all(m > 0.0 for m in self.big_m):
            raise ValueError("big_m entries must be positive")


@dataclass(frozen=True, slots=True)
class FlrFit:
    """Fuzzy line y = (p₀, c₀) + (p₁, c₁) t: centres p and spreads c (eq. 6), LP status."""

    p0: float
    p1: float
    c0: float
    c1: float
    status: int  # scipy linprog status: 0 optimal, 2 infeasible, 3 unbounded, else failure


def flr_line(t: np.ndarray, y: np.ndarray, h: float, big_m: float | None = None) -> FlrFit:
    """Tanaka's possibilistic linear fit of y against t (Garhwal et al. eqs. 6–12).

    Minimises the total spread m c₀ + Σ_j c₁ |t_j| (eq. 10) subject to, for every sample j,
    y_j ≥ p₀ + p₁ t_j − (1 − h)(c₀ + c₁ |t_j|) (eq. 11) and y_j ≤ p₀ + p₁ t_j + (1 − h)(c₀ + c₁ |t_j|)
    (eq. 12), c ≥ 0. Variables [p₀, p₁, c₀, c₁]; ``big_m`` bounds them (see the module docstring).
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    m = t.size
    at = np.abs(t)
    w = 1.0 - h
    cost = np.array([0.0, 0.0, float(m), float(at.sum())])
    # eq. 11: −p₀ − p₁ t + w c₀ + w c₁|t| ≥ −y  →  p₀ + p₁ t − w c₀ − w c₁|t| ≤ y
    a11 = np.column_stack([np.ones(m), t, -w * np.ones(m), -w * at])
    # eq. 12: −p₀ − p₁ t − w c₀ − w c₁|t| ≤ −y
    a12 = np.column_stack([-np.ones(m), -t, -w * np.ones(m), -w * at])
    if big_m is None:
        bounds: list[tuple[float | None, float | None]] = [(None, None), (None, None), (0.0, None), (0.0, None)]
    else:
        span = float(t.max() - t.min())
        m1 = big_m / span if span > 0.0 else big_m
        bounds = [(-big_m, big_m), (-m1, m1), (0.0, big_m), (0.0, m1)]
    res = linprog_solver()(cost, A_ub=np.vstack([a11, a12]), b_ub=np.concatenate([y, -y]), bounds=bounds, method="highs")
    if res.status != 0 or res.x is None:
        return FlrFit(math.nan, math.nan, math.nan, math.nan, int(res.status) if res.status != 0 else 4)
    p0, p1, c0, c1 = (float(v) for v in res.x)
    return FlrFit(p0, p1, c0, c1, 0)


def lsq_slope(t: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y against t (the comparison filter of Garhwal et al.); NaN when
    the times do not span an interval."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    dt = t - t.mean()
    s = float(dt @ dt)
    if not s > 0.0:
        return math.nan
    return float(dt @ (y - y.mean())) / s


def eq1_q(residual: np.ndarray, slope: np.ndarray) -> np.ndarray:
    """Q = |Δx̄ · Δẋ̄| δ_ij (Garhwal et al. eq. 1): diagonal, element i = |Δx̄_i Δẋ̄_i|."""
    return np.diag(np.abs(np.asarray(residual, dtype=float) * np.asarray(slope, dtype=float)))


@dataclass
class AdaptiveQCounters:
    """Cost and outcome of the slope fits of one filter."""

    lp_solves: int = 0
    lp_seconds: float = 0.0
    lp_failures: int = 0  # infeasible, unbounded, solver failure or degenerate window
    fallback_lsq: int = 0
    fallback_previous: int = 0

    @property
    def lp_mean_us(self) -> float:
        return 1e6 * self.lp_seconds / self.lp_solves if self.lp_solves else 0.0

    def add(self, other: "AdaptiveQCounters") -> None:
        self.lp_solves += other.lp_solves
        self.lp_seconds += other.lp_seconds
        self.lp_failures += other.lp_failures
        self.fallback_lsq += other.fallback_lsq
        self.fallback_previous += other.fallback_previous

    def as_counts(self) -> dict[str, int]:
        """The ``RunStatus`` counters: LPs solved, failed, fallbacks, and their total host CPU (µs)."""
        return {
            "adaptive_lp_solves": self.lp_solves,
            "adaptive_lp_failures": self.lp_failures,
            "adaptive_fallback_lsq": self.fallback_lsq,
            "adaptive_fallback_previous": self.fallback_previous,
            "adaptive_lp_us": int(round(1e6 * self.lp_seconds)),
        }


@dataclass
class AdaptiveQ:
    """The residual window and the eq. 1 Q of one filter over ``n_states`` states."""

    config: AdaptiveQConfig
    n_states: int = 6
    counters: AdaptiveQCounters = field(default_factory=AdaptiveQCounters)

    def __post_init__(self) -> None:
        lam = self.config.window
        self._t = np.zeros(lam)
        self._r = np.zeros((lam, self.n_states))
        self._count = 0
        self._head = 0
        self._q = np.zeros(self.n_states)  # diagonal of the last adaptive Q

    @property
    def active(self) -> bool:
        return self.config.mode != "fixed" and self._count >= self.config.warmup

    def add(self, t: float, residual: np.ndarray) -> None:
        """Record the state residual Δx̄ (the update's correction) at epoch t and refit."""
        if self.config.mode == "fixed":
            return
        r = np.asarray(residual, dtype=float)[: self.n_states]
        if r.shape != (self.n_states,) or not np.all(np.isfinite(r)) or not math.isfinite(t):
            return  # a non-finite update never reaches Q; the filter's own checks count it
        lam = self.config.window
        self._t[self._head] = t
        self._r[self._head] = r
        self._head = (self._head + 1) % lam
        self._count = min(self._count + 1, lam)
        if self._count >= self.config.warmup:
            self._refit(r)

    def window(self) -> tuple[np.ndarray, np.ndarray]:
        """(times, residuals) of the window, oldest first, times from the oldest sample."""
        k = self._count
        lam = self.config.window
        idx = (np.arange(self._head - k, self._head)) % lam
        t = self._t[idx]
        return t - t[0], self._r[idx]

    def _refit(self, latest: np.ndarray) -> None:
        t, r = self.window()
        cfg = self.config
        slopes = np.empty(self.n_states)
        for i in range(self.n_states):
            slopes[i] = self._slope(t, r[:, i], None if cfg.big_m is None else cfg.big_m[i])
        q = eq1_q(latest, slopes).diagonal()
        ok = np.isfinite(q)
        self._q = np.where(ok, q, self._q)

    def _slope(self, t: np.ndarray, y: np.ndarray, big_m: float | None) -> float:
        c = self.counters
        if self.config.mode == "lsq-adaptive":
            s = lsq_slope(t, y)
            if not math.isfinite(s):
                c.fallback_previous += 1
            return s
        if not float(t[-1] - t[0]) > 0.0:
            fit_ok = False  # the slope of a window without a time span is not defined
        else:
            t0 = time.perf_counter()
            fit = flr_line(t, y, self.config.h, big_m)
            c.lp_seconds += time.perf_counter() - t0
            c.lp_solves += 1
            fit_ok = fit.status == 0 and math.isfinite(fit.p1)
            if fit_ok:
                return fit.p1
        c.lp_failures += 1
        s = lsq_slope(t, y)
        if math.isfinite(s):
            c.fallback_lsq += 1
        else:
            c.fallback_previous += 1
        return s

    def declared_cost(self) -> float:
        """Work units the next update of this filter is charged for its slope fits: one LP per
        state in fuzzy mode (an upper bound: none run before the window is warm); least squares
        is part of the filter step's own cost."""
        return self.config.lp_cost * self.n_states if self.config.mode == "fuzzy-adaptive" else 0.0

    def q_diagonal(self, dt: float) -> np.ndarray:
        """Diagonal of Q to add over a propagation interval dt: eq. 1 per unit sample interval,
        scaled by dt (the paper samples at 1 s, where the two agree); zero until warm."""
        if not self.active:
            return np.zeros(self.n_states)
        return self._q * abs(dt)

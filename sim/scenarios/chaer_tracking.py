"""The linear 2-state tracking example of Chaer et al. 1997 §V (Chaer, Bishop & Ghosh 1997).

A target moves in a straight line at a constant velocity of 100 m/s, perturbed by process noise
(Chaer et al. 1997 eq. 24):

    x_{k+1} = [[1, Δt], [0, 1]] x_k + w_k,   x = [range, velocity],   Δt = 1 s,

and both range and velocity are measured every second (eq. 25): z_k = x_k + v_k, with
E[w wᵀ] = Q = diag(q1, q2), E[v vᵀ] = R = diag(r1, r2). A bank of five Kalman filters differing
only in α = [q1 q2 r1 r2] (eq. 26) is started from x̂₀⁻ = [0, 0], P₀⁻ = diag(1000, 1000).

This module generates the truth and the measurements only (numpy only, no filter code): the
parameter tables of the three experiments, and a generator for (piecewise-stationary) sequences.

* Experiment 1 (Table I): the truth uses KF 3's parameters, which are in the bank.
* Experiment 2 (Table II): the truth uses KF* = [16 16 16 16], which is not in the bank; KF 3
  ([12 12 20 20]) is the closest.
* Experiment 3 (Table III): five sub-sequences of equal length (100 in the paper); the noise
  statistics of sub-sequence s are those of KF s.

Conventions (the paper leaves them implicit): measurement k is taken at t_k = k Δt, k = 0…K−1;
the truth starts at x₀ = [0 m, 100 m/s]; the process noise that carries x_{k−1} to x_k and the
measurement noise of z_k both use the statistics of the sub-sequence that measurement k belongs to.
Both Q and R change at every boundary (Table III lists all four components per sub-sequence); the
trajectory is continuous across boundaries. The filters are the time-varying KFs of eqs. 2–6 from
the stated P₀⁻ (not steady-state filters: with a steady-state S of a few m² the first residual of
~100 m/s in velocity would cost ~10³ nat and the product of eq. 7 would underflow at once).

What the paper reports, and what this model gives (measured in ``tests/test_gating_magill.py``,
``tests/test_gating_moe.py``; expected log-likelihoods from the steady-state Riccati and Lyapunov
equations in ``tests/test_chaer_bank.py``):

* Underflow of Magill's literal product (§V.C: after measurement 168). With the normaliser printed
  in eqs. 7/13/22, (2π|W|)^{−1/2}: after 169 (165–173); with the 2-variate density: after 142.
  See ``fsw.gating.magill``.
* Magill switch to KF 2 (§V.C: after measurement 110). 300 runs: median 21 after the change
  (10–90 %: 13–32); 8 % of runs are within 10, and those runs underflow at 165–170 — the paper's
  run is a plausible single realisation. KF 1 leads KF 2 by 1.06 nat per measurement in segment 1
  and loses 5.7 nat per measurement in segment 2.
* Gating network switch (§V.C: after measurement 103, η = 1). The paper does not define "switch".
  With φ = [1] (see ``fsw.gating.moe`` for why not the raw z of eq. 12), KF 1's weight falls below
  0.9 of its pre-change value a median 4 after the change ("onset"), and KF 2 takes the largest
  weight a median 10 after it ("top"); in the runs where Magill switches within 10 (like the
  paper's), onset is 2–5 and top 5–9. η = 7 gives top after a median 3.
* Segments 3–5 are intrinsically harder: the matching filter beats the runner-up by only 0.48,
  0.31 and 0.57 nat per measurement (segment 2: 0.33, but against KF 1 it is 5.7), so any
  likelihood-driven gate needs tens of measurements there. Magill without a lower bound mostly does
  not follow them within their 100 measurements.
* Experiments 1–2 (§V.A–B: KF 3 selected "quite rapid" for η = 0.1 and 1). KF 2, KF 4 and KF 5 are
  within 0.02–0.05 nat per measurement of KF 3 (Table I: 0.033 to KF 4; Table II: 0.023), so even
  the exact Bayesian posterior needs ~100–300 measurements; the gating network with φ = [1] gives
  KF 3 0.74 (Exp. 1) / 0.45 (Exp. 2) after 1000 at η = 1, > 0.9 by 300 at η = 7, and at η = 0.1
  hardly moves from 0.2. Not reproduced;
  nothing in §V (tables, initial conditions, sampling) would change these separations.
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np

DT = 1.0
"""Measurement interval Δt [s] (Chaer et al. 1997 §V)."""

TRUE_INITIAL_STATE = (0.0, 100.0)
"""Truth x₀: range 0 m, velocity 100 m/s (Chaer et al. 1997 §V: constant velocity of 100 m/s)."""

FILTER_INITIAL_STATE = (0.0, 0.0)
"""Filter a-priori x̂₀⁻ (Chaer et al. 1997 §V)."""

FILTER_INITIAL_COVARIANCE = ((1000.0, 0.0), (0.0, 1000.0))
"""Filter a-priori P₀⁻ (Chaer et al. 1997 §V)."""

TRANSITION = ((1.0, DT), (0.0, 1.0))
"""State transition matrix Φ of Chaer et al. 1997 eq. 24."""

MEASUREMENT_MATRIX = ((1.0, 0.0), (0.0, 1.0))
"""Observation matrix H of Chaer et al. 1997 eq. 25."""

# Rows are filters KF 1..KF 5, columns α = [q1, q2, r1, r2] (Chaer et al. 1997 eq. 26).
TABLE_I = ((1.0, 1.0, 1.0, 1.0), (9.0, 9.0, 25.0, 25.0), (16.0, 16.0, 16.0, 16.0),
           (25.0, 25.0, 9.0, 9.0), (5.0, 20.0, 25.0, 10.0))
"""Chaer et al. 1997 Table I: filter bank containing the optimal filter (KF 3)."""

TABLE_I_TRUTH = TABLE_I[2]
"""Experiment 1 truth: KF 3's parameters."""

TABLE_II = ((1.0, 1.0, 1.0, 1.0), (9.0, 9.0, 25.0, 25.0), (12.0, 12.0, 20.0, 20.0),
            (25.0, 25.0, 9.0, 9.0), (5.0, 20.0, 25.0, 10.0))
"""Chaer et al. 1997 Table II: filter bank not containing the optimal filter KF*."""

TABLE_II_TRUTH = (16.0, 16.0, 16.0, 16.0)
"""Experiment 2 truth: KF* of Table II."""

TABLE_III = ((1.0, 1.0, 1.0, 1.0), (10.0, 25.0, 1.0, 1.0), (10.0, 10.0, 16.0, 16.0),
             (5.0, 25.0, 2.0, 25.0), (1.0, 1.0, 2.0, 50.0))
"""Chaer et al. 1997 Table III: filter bank of the switching experiment; sub-sequence s uses row s."""

EXPERIMENT_3_SEGMENT_LENGTH = 100
"""Length of each of the five sub-sequences of Experiment 3 (Chaer et al. 1997 §V.C)."""


PAPER_UNDERFLOW_MEASUREMENT = 168
"""Chaer et al. 1997 §V.C: Magill's product form underflows after this many measurements of Experiment 3."""

PAPER_SWITCH_MEASUREMENT = {"moe": 103, "magill": 110}
"""Chaer et al. 1997 §V.C: measurement after which each scheme switches from KF 1 to KF 2 (η = 1 gate)."""


class TrackingRun(NamedTuple):
    """Truth and measurements of one tracking sequence (all plain numpy arrays).

    t : (K,) measurement times [s]; x : (K, 2) true [range m, velocity m/s] at t;
    z : (K, 2) measurements; segment : (K,) index of the noise parameter set in force;
    alpha : (S, 4) the parameter sets [q1, q2, r1, r2] of the segments.
    """

    t: np.ndarray
    x: np.ndarray
    z: np.ndarray
    segment: np.ndarray
    alpha: np.ndarray


def _as_alpha(params: Sequence[Sequence[float]]) -> np.ndarray:
    alpha = np.asarray(params, dtype=float)
    if alpha.ndim != 2 or alpha.shape[1] != 4:
        raise ValueError(f"parameter sets must have shape (S, 4) [q1 q2 r1 r2], got {alpha.shape}")
    if not np.all(np.isfinite(alpha)) or np.any(alpha < 0.0):
        raise ValueError("noise variances must be finite and non-negative")
    return alpha


def generate(
    params: Sequence[Sequence[float]],
    lengths: Sequence[int] | int,
    rng: np.random.Generator,
    x0: Sequence[float] = TRUE_INITIAL_STATE,
) -> TrackingRun:
    """Simulate a piecewise-stationary sequence: segment s has length ``lengths[s]`` and noise
    variances ``params[s] = (q1, q2, r1, r2)`` (Chaer et al. 1997 eqs. 24–25).

    The state is continuous across segment boundaries; only the noise statistics change.
    """
    alpha = _as_alpha(params)
    n_seg = alpha.shape[0]
    if isinstance(lengths, (int, np.integer)):
        lengths = [int(lengths)] * n_seg
    lens = np.asarray(lengths, dtype=int)
    if lens.shape != (n_seg,) or np.any(lens < 1):
        raise ValueError(f"need {n_seg} positive segment lengths, got {lengths!r}")
    segment = np.repeat(np.arange(n_seg), lens)
    k_total = int(lens.sum())
    sd = np.sqrt(alpha[segment])  # (K, 4)
    w = rng.standard_normal((k_total, 2)) * sd[:, 0:2]
    v = rng.standard_normal((k_total, 2)) * sd[:, 2:4]
    # x_k = Φ x_{k-1} + w_k with Φ = [[1, Δt], [0, 1]]: the velocity is a random walk and the
    # range integrates it, so both follow from cumulative sums (no Python loop).
    vel = x0[1] + np.concatenate(([0.0], np.cumsum(w[1:, 1])))
    rng_pos = x0[0] + np.concatenate(([0.0], np.cumsum(DT * vel[:-1] + w[1:, 0])))
    x = np.column_stack((rng_pos, vel))
    z = x + v
    t = DT * np.arange(k_total, dtype=float)
    return TrackingRun(t=t, x=x, z=z, segment=segment, alpha=alpha)


#: Table IV (Chaer et al. 1997 §V.D, Experiment 4): the bank before the first RQP adaptation.
TABLE_IV = ((20.0, 20.0, 20.0, 20.0), (0.0, 0.0, 5.0, 5.0), (10.0, 10.0, 1.0, 1.0),
            (5.0, 5.0, 5.0, 5.0), (50.0, 50.0, 50.0, 50.0))
#: Experiment 4's "actual solution" α* (§V.D); the paper does not state the generating parameters,
#: so the truth is simulated with α* itself.
EXPERIMENT_4_TRUTH = (4.31, 22.45, 24.01, 11.42)
#: What the paper's first adaptation (t = 200 s, from KF 1) found.
EXPERIMENT_4_PAPER_FIRST = (4.70, 20.69, 22.83, 14.54)
EXPERIMENT_4_PERIOD = 200


def experiment_4(rng: np.random.Generator, length: int = 1000) -> TrackingRun:
    """Experiment 4 (Chaer et al. 1997 §V.D): truth with α* (see :data:`EXPERIMENT_4_TRUTH`)."""
    return generate([EXPERIMENT_4_TRUTH], length, rng)


def experiment_1(rng: np.random.Generator, length: int = 300) -> TrackingRun:
    """Experiment 1 (Chaer et al. 1997 §V.A): truth with KF 3's Table I parameters."""
    return generate([TABLE_I_TRUTH], length, rng)


def experiment_2(rng: np.random.Generator, length: int = 300) -> TrackingRun:
    """Experiment 2 (Chaer et al. 1997 §V.B): truth with KF* = [16 16 16 16] (Table II)."""
    return generate([TABLE_II_TRUTH], length, rng)


def experiment_3(rng: np.random.Generator, segment_length: int = EXPERIMENT_3_SEGMENT_LENGTH) -> TrackingRun:
    """Experiment 3 (Chaer et al. 1997 §V.C): five sub-sequences, sub-sequence s matching KF s of Table III."""
    return generate(TABLE_III, segment_length, rng)


def bank_parameters(experiment: int) -> np.ndarray:
    """The (5, 4) α table of the filter bank of Experiment 1, 2, 3 or 4."""
    tables = {1: TABLE_I, 2: TABLE_II, 3: TABLE_III, 4: TABLE_IV}
    if experiment not in tables:
        raise ValueError(f"experiment must be 1, 2, 3 or 4, got {experiment!r}")
    return np.asarray(tables[experiment], dtype=float)

def switch_delays(
    weights: np.ndarray, segment_length: int = EXPERIMENT_3_SEGMENT_LENGTH, rule: str = "top",
    onset_fraction: float = 0.9,
) -> np.ndarray:
    """Delay, in measurements, of a weight history's reaction to each regime change of Experiment 3.

    ``weights`` (K, N) has one row per measurement; sub-sequence s (0-based) should select filter s.
    For each change s = 1..K/segment_length − 1, counting the first measurement of the new
    sub-sequence as 1 (Chaer et al.'s (1997) "after measurement 103" for a change after 100 is a delay of 3):

    * ``rule = "top"``: until filter s first has the largest weight;
    * ``rule = "onset"``: until the filter that was on top at the end of sub-sequence s − 1 first has
      less than ``onset_fraction`` of the weight it had then (the need to switch is detected).

    ``segment_length + 1`` means it did not happen within the sub-sequence.
    """
    W = np.asarray(weights, dtype=float)
    if W.ndim != 2 or W.shape[0] < 2 * segment_length or W.shape[0] % segment_length:
        raise ValueError(f"weights must be (S*{segment_length}, N) with S >= 2, got {W.shape}")
    if rule not in ("top", "onset"):
        raise ValueError(f"rule must be 'top' or 'onset', got {rule!r}")
    if not 0.0 < onset_fraction < 1.0:
        raise ValueError("onset_fraction must be in (0, 1)")
    n_seg = W.shape[0] // segment_length
    if W.shape[1] < n_seg:
        raise ValueError(f"{n_seg} sub-sequences need at least {n_seg} filters")
    out = np.full(n_seg - 1, segment_length + 1, dtype=int)
    for s in range(1, n_seg):
        seg = W[s * segment_length:(s + 1) * segment_length]
        if rule == "top":
            hit = np.argmax(seg, axis=1) == s
        else:
            before = W[s * segment_length - 1]
            prev = int(np.argmax(before))
            hit = seg[:, prev] < onset_fraction * before[prev]
        idx = np.flatnonzero(hit)
        if idx.size:
            out[s - 1] = int(idx[0]) + 1
    return out

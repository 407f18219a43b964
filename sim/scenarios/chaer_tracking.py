"""The linear 2-state tracking example of seed 003 §V (Chaer, Bishop & Ghosh 1997).

A target moves in a straight line at a constant velocity of 100 m/s, perturbed by process noise
(seed 003 eq. 24):

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
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np

DT = 1.0
"""Measurement interval Δt [s] (seed 003 §V)."""

TRUE_INITIAL_STATE = (0.0, 100.0)
"""Truth x₀: range 0 m, velocity 100 m/s (seed 003 §V: constant velocity of 100 m/s)."""

FILTER_INITIAL_STATE = (0.0, 0.0)
"""Filter a-priori x̂₀⁻ (seed 003 §V)."""

FILTER_INITIAL_COVARIANCE = ((1000.0, 0.0), (0.0, 1000.0))
"""Filter a-priori P₀⁻ (seed 003 §V)."""

TRANSITION = ((1.0, DT), (0.0, 1.0))
"""State transition matrix Φ of seed 003 eq. 24."""

MEASUREMENT_MATRIX = ((1.0, 0.0), (0.0, 1.0))
"""Observation matrix H of seed 003 eq. 25."""

# Rows are filters KF 1..KF 5, columns α = [q1, q2, r1, r2] (seed 003 eq. 26).
TABLE_I = ((1.0, 1.0, 1.0, 1.0), (9.0, 9.0, 25.0, 25.0), (16.0, 16.0, 16.0, 16.0),
           (25.0, 25.0, 9.0, 9.0), (5.0, 20.0, 25.0, 10.0))
"""Seed 003 Table I: filter bank containing the optimal filter (KF 3)."""

TABLE_I_TRUTH = TABLE_I[2]
"""Experiment 1 truth: KF 3's parameters."""

TABLE_II = ((1.0, 1.0, 1.0, 1.0), (9.0, 9.0, 25.0, 25.0), (12.0, 12.0, 20.0, 20.0),
            (25.0, 25.0, 9.0, 9.0), (5.0, 20.0, 25.0, 10.0))
"""Seed 003 Table II: filter bank not containing the optimal filter KF*."""

TABLE_II_TRUTH = (16.0, 16.0, 16.0, 16.0)
"""Experiment 2 truth: KF* of Table II."""

TABLE_III = ((1.0, 1.0, 1.0, 1.0), (10.0, 25.0, 1.0, 1.0), (10.0, 10.0, 16.0, 16.0),
             (5.0, 25.0, 2.0, 25.0), (1.0, 1.0, 2.0, 50.0))
"""Seed 003 Table III: filter bank of the switching experiment; sub-sequence s uses row s."""

EXPERIMENT_3_SEGMENT_LENGTH = 100
"""Length of each of the five sub-sequences of Experiment 3 (seed 003 §V.C)."""


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
    variances ``params[s] = (q1, q2, r1, r2)`` (seed 003 eqs. 24–25).

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


def experiment_1(rng: np.random.Generator, length: int = 300) -> TrackingRun:
    """Experiment 1 (seed 003 §V.A): truth with KF 3's Table I parameters."""
    return generate([TABLE_I_TRUTH], length, rng)


def experiment_2(rng: np.random.Generator, length: int = 300) -> TrackingRun:
    """Experiment 2 (seed 003 §V.B): truth with KF* = [16 16 16 16] (Table II)."""
    return generate([TABLE_II_TRUTH], length, rng)


def experiment_3(rng: np.random.Generator, segment_length: int = EXPERIMENT_3_SEGMENT_LENGTH) -> TrackingRun:
    """Experiment 3 (seed 003 §V.C): five sub-sequences, sub-sequence s matching KF s of Table III."""
    return generate(TABLE_III, segment_length, rng)


def bank_parameters(experiment: int) -> np.ndarray:
    """The (5, 4) α table of the filter bank of Experiment 1, 2 or 3."""
    tables = {1: TABLE_I, 2: TABLE_II, 3: TABLE_III}
    if experiment not in tables:
        raise ValueError(f"experiment must be 1, 2 or 3, got {experiment!r}")
    return np.asarray(tables[experiment], dtype=float)

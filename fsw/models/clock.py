"""The onboard clock error model: phase b [s], fractional frequency f [1], drift a [1/s].

    db/dt = f + w1,   df/dt = a + w2,   da/dt = w3,

with white noises of spectral densities q1 [s] (white FM), q2 [1/s] (random-walk FM) and q3
[1/s³] (random-run FM); Allan variance σ_y²(τ) = q1/τ + q2 τ/3 + q3 τ³/20 (the standard
three-state clock model, Zucca & Tavella 2005). Over a step h the transition is
Φ = [[1, h, h²/2], [0, 1, h], [0, 0, 1]] and the exact discrete process noise is

    Q11 = q1 h + q2 h³/3 + q3 h⁵/20   Q12 = q2 h²/2 + q3 h⁴/8   Q13 = q3 h³/6
    Q22 = q2 h + q3 h³/3               Q23 = q3 h²/2              Q33 = q3 h.

A filter with fewer components (phase only, phase + frequency) uses the leading block.
Defaults are DSAC-class (~2e-15 Allan deviation at one day, drift ~3e-16/day).
"""

from __future__ import annotations

import numpy as np

DEFAULT_Q_WHITE_FM_S = (1.6e-15) ** 2 * 86400.0
DEFAULT_Q_RANDOM_WALK_FM_PER_S = 3.0 * ((2.0e-15) ** 2 - (1.6e-15) ** 2) / 86400.0
DEFAULT_Q_RANDOM_RUN_PER_S3 = 1.0e-50


def clock_transition(h: float, k: int = 3) -> np.ndarray:
    """Φ(h) of the first k clock components."""
    F = np.array([[1.0, h, 0.5 * h * h], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
    return F[:k, :k]


def clock_process_noise(h: float, q: np.ndarray) -> np.ndarray:
    """Exact discrete Q (N, 3, 3) over a step h for spectral densities q (N, 3) = (q1, q2, q3)."""
    h2 = h * h
    h3 = h2 * h
    basis = np.array((
        ((h, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        ((h3 / 3.0, h2 / 2.0, 0.0), (h2 / 2.0, h, 0.0), (0.0, 0.0, 0.0)),
        ((h3 * h2 / 20.0, h2 * h2 / 8.0, h3 / 6.0), (h2 * h2 / 8.0, h3 / 3.0, h2 / 2.0), (h3 / 6.0, h2 / 2.0, h)),
    ))
    return np.matmul(q, basis.reshape(3, 9)).reshape(q.shape[0], 3, 3)

"""Bank outputs: the weighted-sum estimate and the best-filter estimate.

Chaer et al. 1997 eq. 3 (and Lubey & Ely 2022 §2): x̂_opt = Σ_i p_i x̂_i, the gating weights p_i summing to one.
Its covariance is the mixture covariance Σ_i p_i [P_i + (x̂_i − x̂_opt)(x̂_i − x̂_opt)ᵀ], which
accounts for the spread between filters as well as each filter's own uncertainty.
The alternative of Lubey & Ely 2022 §2 is to take the estimate of the filter with the highest weight.
"""

from __future__ import annotations

import math

import numpy as np


def normalised_weights(weights: np.ndarray, active: np.ndarray) -> np.ndarray:
    """Weights with disabled filters zeroed and the rest renormalised to sum to one."""
    w = np.where(active, np.asarray(weights, dtype=float), 0.0)
    # a few numbers: checked as Python floats (NaN fails isfinite whatever min makes of it)
    values = w.tolist()
    if not all(map(math.isfinite, values)) or (values and min(values) < 0.0):
        raise ValueError("weights must be finite and non-negative")
    total = w.sum()
    if total <= 0.0:
        raise ValueError("no active filter has a positive weight")
    return w / total


def weighted_estimate(x: np.ndarray, P: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted-sum estimate and mixture covariance from stacks x (N, n), P (N, n, n)."""
    w = np.asarray(weights, dtype=float)
    x_opt = np.einsum("i,ij->j", w, x)
    d = x - x_opt
    P_opt = np.einsum("i,ijk->jk", w, P) + np.einsum("i,ij,ik->jk", w, d, d)
    return x_opt, 0.5 * (P_opt + P_opt.T)


def best_index(weights: np.ndarray, active: np.ndarray) -> int:
    """Index of the active filter with the highest weight (first one on ties)."""
    w = np.where(active, np.asarray(weights, dtype=float), -np.inf)
    return int(np.argmax(w))

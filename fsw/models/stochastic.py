"""Exponentially correlated random variables (ECRV, first-order Gauss–Markov), Chaer et al. 1998 eqs. 25–26.

    x_{k+1} = exp(−Δt/τ) x_k + w_k,      E[w_k²] = σ² (1 − exp(−2Δt/τ))          (25), (26)

σ is the steady-state deviation. Lubey & Ely 2022 Table 1 estimates such parameters "in discrete
batches": the value is constant over a batch of length T_b and steps by eq. 25 with Δt = T_b
at each batch boundary. A process with no correlation between batches (the ACS daily
variation, the batched polynomial acceleration) is the limit τ → 0: m = 0, q = σ².

For an estimated parameter with covariance row P_x·, the step is x ← m x, P_xx ← m² P_xx + q,
P_x,other ← m P_x,other.
"""

from __future__ import annotations

import math

import numpy as np


def ecrv_factors(dt: float, tau: float | None, sigma: float) -> tuple[float, float]:
    """(m, q) of eqs. 25–26 for a step Δt; ``tau`` None or 0 means uncorrelated (m = 0, q = σ²)."""
    if dt < 0.0:
        raise ValueError("ECRV step must be non-negative")
    if tau is None or tau == 0.0:
        return 0.0, sigma * sigma
    m = math.exp(-dt / tau)
    return m, sigma * sigma * (1.0 - m * m)


def batch_boundaries(t0: float, t1: float, length: float, origin: float = 0.0) -> np.ndarray:
    """Batch boundaries origin + k·length in the half-open interval (t0, t1]."""
    if length <= 0.0 or t1 <= t0:
        return np.empty(0)
    k0 = math.floor((t0 - origin) / length) + 1
    k1 = math.floor((t1 - origin) / length)
    return origin + length * np.arange(k0, k1 + 1, dtype=float)


def apply_ecrv_step(x: np.ndarray, P: np.ndarray, index: int, m: np.ndarray, q: np.ndarray) -> None:
    """In place, for a stack x (N, n), P (N, n, n): parameter ``index`` steps with factors m, q (N,)."""
    x[:, index] *= m
    P[:, index, :] *= m[:, None]
    P[:, :, index] *= m[:, None]
    P[:, index, index] += q

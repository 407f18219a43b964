"""Compiled kernel: the bank's weighted-sum estimate and its mixture covariance.

Chaer et al. 1997 eq. 3 (Lubey & Ely 2022 §2) over the filters ``rows`` with weights p_i summing
to one, on the states ``cols`` they all estimate:

    x̂_opt = Σ_i p_i x̂_i,
    P_opt = Σ_i p_i P_i + Σ_i p_i (x̂_i − x̂_opt)(x̂_i − x̂_opt)ᵀ,

made exactly symmetric (the mean of P_opt and its transpose).

It is :func:`fsw.filters.combine.weighted_estimate` on the gathered rows and columns, to the bit:
each sum starts from 0 and adds the filters' terms in order, a spread term is (p_i dᵢ_a) dᵢ_b,
and the two covariance sums are added last — what numpy's ``einsum`` does there
(``tests/test_kernels_mixture_estimate.py`` holds the two to equality). One call instead of two
fancy-index gathers and three ``einsum`` calls: the estimates go out every hour of a run, and the
gathers and the ``einsum`` calls' set-up were most of their cost.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit("void(float64[:, ::1], float64[:, :, ::1], float64[::1], int64[::1], int64[::1], float64[::1], "
      "float64[:, ::1])", cache=True)
def mixture_estimate(x, P, w, rows, cols, x_out, P_out):
    """x (N, n), P (N, n, n) of the bank, weights w (N,); ``rows`` the filters combined, ``cols``
    the states taken → x̂_opt (k,) in ``x_out`` and P_opt (k, k) in ``P_out``, k = cols.size."""
    k = cols.size
    n_r = rows.size
    for a in range(k):
        x_out[a] = 0.0
    for r in range(n_r):
        i = rows[r]
        wi = w[i]
        for a in range(k):
            x_out[a] += wi * x[i, cols[a]]
    d = np.empty((n_r, k))
    for r in range(n_r):
        i = rows[r]
        for a in range(k):
            d[r, a] = x[i, cols[a]] - x_out[a]
    spread = np.zeros((k, k))
    for a in range(k):
        for b in range(k):
            P_out[a, b] = 0.0
    for r in range(n_r):
        i = rows[r]
        wi = w[i]
        for a in range(k):
            ca = cols[a]
            wd = wi * d[r, a]
            for b in range(k):
                P_out[a, b] += wi * P[i, ca, cols[b]]
                spread[a, b] += wd * d[r, b]
    for a in range(k):
        for b in range(k):
            P_out[a, b] += spread[a, b]
    for a in range(k):
        P_out[a, a] = 0.5 * (P_out[a, a] + P_out[a, a])
        for b in range(a + 1, k):
            v = 0.5 * (P_out[a, b] + P_out[b, a])
            P_out[a, b] = v
            P_out[b, a] = v

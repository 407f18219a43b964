"""Compiled kernel: one measurement's Magill update of the bank's weights, in the log domain.

For every filter i the Gaussian log-likelihood of the measurement (Lubey & Ely 2022 eq. 4),

    ln f(y | α_i) = −½ (z̄ᵢᵀ Sᵢ⁻¹ z̄ᵢ + ln |Sᵢ| + n ln 2π),

then the sequential Bayes rule (Lubey & Ely 2022 eq. 3, Chaer et al. 1997 eqs. 7–8) on ln p,
normalised with log-sum-exp over the enabled filters:

    ln p_k,i = ln p_k−1,i + ln f(y | α_i) − ln Σ_j exp(ln p_k−1,j + ln f(y | α_j)),

and the weights p_k,i themselves. :mod:`fsw.gating.magill` explains the log domain and carries
the Python form of the same arithmetic (any n, and the Hanlon & Maybeck 2000 lower bound, which
it applies to this kernel's result).

The log-likelihood is the Python form's to the bit (the chi-square, ``math.log`` of S or of the
2 × 2 LU pivots, the same sums in the same order). The normalisation and the weights take the C
library's exp and log, which differ from numpy's vectorised ones in the last bit of a few per
cent of arguments: ``tests/test_gating_magill.py`` holds the weights to the recursion written out
with numpy within 1e-13 relative (on the default run: 1 ulp in one update of forty).
"""

from __future__ import annotations

import math

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources
from fsw.kernels.codes import MAGILL_NOT_POSITIVE_DEFINITE, MAGILL_OK, MAGILL_UNHANDLED_DIMENSION

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit(cache=True)
def _logdet_2x2(a, b, c, d):
    """ln |det [[a, b], [c, d]]| by LU with partial pivoting, the multiplier formed with the
    pivot's reciprocal (``fsw.gating.magill._logdet_2x2``, slogdet's operations); NaN where the
    determinant is not positive."""
    if abs(c) > abs(a):  # rows swapped: the determinant changes sign
        p = c
        r = 1.0 / c
        u = b - (a * r) * d
        sign = -1.0
    else:
        if a == 0.0:
            return math.nan
        p = a
        r = 1.0 / a
        u = d - (c * r) * b
        sign = 1.0
    if u == 0.0 or ((p > 0.0) == (u > 0.0)) != (sign > 0.0):
        return math.nan
    return math.log(abs(p)) + math.log(abs(u))


@njit("int64(float64[::1], float64[:, :, ::1], boolean[::1], float64[::1], float64, float64[::1], float64[::1], "
      "float64[::1])", cache=True)
def magill_update(chi2, S, active, logp, log_2pi, loglik, logp_out, weights):
    """chi2 (N,) z̄ᵀS⁻¹z̄ and S (N, n, n) of one measurement, the enabled filters ``active`` (N,)
    and ln p before it (−inf where disabled) → ln f(y | α_i) (``loglik``), ln p after it and p.

    Returns ``MAGILL_OK``; ``MAGILL_NOT_POSITIVE_DEFINITE`` (outputs unspecified) where an S is
    not positive definite; ``MAGILL_UNHANDLED_DIMENSION`` for n > 2 (the Python form's slogdet
    takes those)."""
    N = chi2.shape[0]
    n = S.shape[1]
    if n > 2:
        return MAGILL_UNHANDLED_DIMENSION
    for i in range(N):
        if n == 1:
            v = S[i, 0, 0]
            if not v > 0.0:
                return MAGILL_NOT_POSITIVE_DEFINITE
            loglik[i] = -0.5 * (chi2[i] + math.log(v) + log_2pi)
        else:
            logdet = _logdet_2x2(S[i, 0, 0], S[i, 0, 1], S[i, 1, 0], S[i, 1, 1])
            if math.isnan(logdet):
                return MAGILL_NOT_POSITIVE_DEFINITE
            loglik[i] = -0.5 * (chi2[i] + logdet + 2 * log_2pi)
    # log-sum-exp over the enabled filters, the largest term first taken out
    top = -math.inf
    for i in range(N):
        if active[i]:
            v = logp[i] + loglik[i]
            logp_out[i] = v
            if v > top:
                top = v
    total = 0.0
    for i in range(N):
        if active[i]:
            total += math.exp(logp_out[i] - top)
    norm = top + math.log(total)
    for i in range(N):
        if active[i]:
            logp_out[i] = logp_out[i] - norm
            weights[i] = math.exp(logp_out[i])
        else:
            logp_out[i] = -math.inf
            weights[i] = 0.0
    return MAGILL_OK

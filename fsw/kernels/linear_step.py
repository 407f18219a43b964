"""Compiled kernel: one step of the linear filter bank (Chaer et al. 1997 eqs. 2–6), every filter.

Per filter i that is active, with x̄, P̄ the prior (the predicted state and covariance, or the
current ones for an update without a transition step):

    x̄ = F x,  P̄ = F P Fᵀ + Q                               (time update, when ``predict``)
    z̄ = z − H x̄,  S = H P̄ Hᵀ + R,  χ² = z̄ᵀ S⁻¹ z̄           (Lubey & Ely 2022 eq. 6)
    K = P̄ Hᵀ S⁻¹,  X = I − K H
    x⁺ = X x̄ + K z,  P⁺ = X P̄ Xᵀ + K R Kᵀ                  (Joseph form, evaluated explicitly)

A filter that does not process the measurement (``does``) or whose χ² exceeds its ``gate``
keeps x̄ and P̄; it still reports z̄, S and χ², which the gating networks need.

Why the Joseph form is evaluated explicitly, with X formed first: where a measurement is many
orders of magnitude stronger than the prior (R ≪ H P̄ Hᵀ), P⁺ is that much smaller than P̄. The
expanded forms (P̄ − K H P̄, or the congruence of the joint prior in
:func:`fsw.filters.kalman.update`) subtract terms of size ‖P̄‖, and their rounding swamps P⁺. In
X P̄ Xᵀ the small X = I − KH scales P̄ down before anything is summed, so each product's
rounding is relative to P⁺'s own terms; an absolute rounding δ of X's entries moves P⁺ by
δP⁺ + P⁺δᵀ + δP̄δᵀ (as X P̄ = P⁺ for the optimal gain). P⁺ is a congruence of the positive
semi-definite diag(P̄, R), so it stays PSD for any gain. P⁺ is made exactly symmetric (the
mean of the product and its transpose), so rounding asymmetry never accumulates.
Linear bank SPD test (``tests/test_filters_linear.py``: P̄ ≈ diag(1e6, 1e4, 1e2),
R = 1e-8 I₂), each entry of P⁺ against √(P⁺ᵢᵢP⁺ⱼⱼ) of an exact rational evaluation of the same
update: the expanded form is off by 1.3e-2 at the first update, this one by 1.7e-16; 6.9e-5 at
the second, whose P̄ is nearly singular (eigenvalues 11 orders of magnitude apart); 1.5e-16
from the third on.

The four n × n products of a filter (F P, (F P) Fᵀ, X P̄, (X P̄) Xᵀ) go to BLAS through
``np.dot``, with the right-hand operands Fᵀ and Xᵀ formed contiguous (numba copies a transposed
operand: 570 instead of 265 ns a 15 × 15 product); everything of width m (H P̄, S, the gain,
χ²) is written out, with the loops that do not sum innermost; S and S⁻¹ as the EKF's update
forms them (:func:`fsw.kernels.joseph_update.innovation_covariance`), LAPACK's inverse for m > 2.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()

from fsw.kernels.joseph_update import innovation_covariance  # noqa: E402


@njit(cache=True)
def _transposed_times(A, B, out):
    """out = Aᵀ B for A (k, p) and B (k, n) of a small k, the loop over n innermost."""
    k, n = B.shape
    for l in range(A.shape[1]):
        for b in range(n):
            out[l, b] = 0.0
        for j in range(k):
            g = A[j, l]
            for b in range(n):
                out[l, b] += g * B[j, b]


@njit("void(float64[:, :, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, :, ::1], "
      "float64[:, ::1], float64[:, :, ::1], float64[::1], boolean[::1], boolean[::1], float64[::1], boolean, "
      "float64[:, ::1], float64[:, :, ::1], float64[::1], boolean[::1])", cache=True)
def linear_step(F, FT, Q, H, R, x, P, z, active, does, gate, predict, residual, S_out, chi2_out, processed_out):
    """F, Fᵀ, Q (N, n, n), H (N, m, n), R (N, m, m); the states x (N, n) and covariances P
    (N, n, n), advanced in place; the measurement z (m,); ``active``, ``does`` (N,) which
    filters run and which of those process z; ``gate`` (N,) their χ² thresholds (inf: no
    editing); ``predict``: do the time update first → z̄ (N, m), S (N, m, m), χ² (N,) and
    which filters updated (N,). An inactive filter is left untouched and gets NaN outputs."""
    N, n, _ = P.shape
    m = H.shape[1]
    FP = np.empty((n, n))
    Pb = np.empty((n, n))
    xb = np.empty(n)
    HP = np.empty((m, n))
    Sinv = np.empty((m, m))
    KT = np.empty((m, n))  # Kᵀ
    KRT = np.empty((m, n))  # (K R)ᵀ
    X = np.empty((n, n))
    XT = np.empty((n, n))
    Y = np.empty((n, n))
    Pn = np.empty((n, n))
    acc = np.empty(n)
    for i in range(N):
        if not active[i]:
            for j in range(m):
                residual[i, j] = np.nan
                for l in range(m):
                    S_out[i, j, l] = np.nan
            chi2_out[i] = np.nan
            processed_out[i] = False
            continue
        # prior x̄, P̄; loops that do not sum run innermost, so the compiler vectorises them
        if predict:
            np.dot(F[i], P[i], FP)
            np.dot(FP, FT[i], Pb)
            for a in range(n):
                xb[a] = 0.0
                for b in range(n):
                    Pb[a, b] += Q[i, a, b]
            for k in range(n):
                xk = x[i, k]
                for a in range(n):
                    xb[a] += FT[i, k, a] * xk
        else:
            for a in range(n):
                xb[a] = x[i, a]
                for b in range(n):
                    Pb[a, b] = P[i, a, b]
        # H P̄, S = H P̄ Hᵀ + R, z̄ = z − H x̄
        for j in range(m):
            for b in range(n):
                HP[j, b] = 0.0
            yh = 0.0
            for k in range(n):
                h = H[i, j, k]
                yh += h * xb[k]
                for b in range(n):
                    HP[j, b] += h * Pb[k, b]
            residual[i, j] = z[j] - yh
        innovation_covariance(HP, H[i], R[i], S_out[i], Sinv)
        if m > 2:
            Sinv[:, :] = np.linalg.inv(S_out[i])
        chi2 = 0.0
        for j in range(m):
            s = 0.0
            for l in range(m):
                s += Sinv[j, l] * residual[i, l]
            chi2 += residual[i, j] * s
        chi2_out[i] = chi2
        ok = does[i] and (gate[i] == np.inf or chi2 <= gate[i])
        processed_out[i] = ok
        if not ok:
            for a in range(n):
                x[i, a] = xb[a]
                for b in range(n):
                    P[i, a, b] = Pb[a, b]
            continue
        # Kᵀ = S⁻ᵀ H P̄ (P̄ Hᵀ = (H P̄)ᵀ up to P̄'s rounding asymmetry), (K R)ᵀ = Rᵀ Kᵀ
        _transposed_times(Sinv, HP, KT)
        _transposed_times(R[i], KT, KRT)
        # X = I − K H and Xᵀ (BLAS would copy a transposed operand); x⁺ = X x̄ + K z
        _transposed_times(KT, H[i], X)  # K H
        for a in range(n):
            for b in range(n):
                X[a, b] = 0.0 - X[a, b]
            X[a, a] += 1.0
        for a in range(n):
            for b in range(n):
                XT[a, b] = X[b, a]
        for a in range(n):
            acc[a] = 0.0
        for k in range(n):
            xk = xb[k]
            for a in range(n):
                acc[a] += XT[k, a] * xk
        for j in range(m):
            zj = z[j]
            for a in range(n):
                acc[a] += KT[j, a] * zj
        for a in range(n):
            x[i, a] = acc[a]
        # P⁺ = X P̄ Xᵀ + K R Kᵀ, made exactly symmetric
        np.dot(X, Pb, Y)
        np.dot(Y, XT, Pn)
        for a in range(n):
            for j in range(m):
                g = KRT[j, a]
                for b in range(n):
                    Pn[a, b] += g * KT[j, b]
        for a in range(n):
            P[i, a, a] = Pn[a, a]
            for b in range(a + 1, n):
                v = 0.5 * (Pn[a, b] + Pn[b, a])
                P[i, a, b] = v
                P[i, b, a] = v

"""Compiled kernel: the EKF bank's Joseph-form measurement update of N filters.

The arithmetic of :func:`fsw.filters.kalman.update` (its docstring derives it), for
measurements of dimension m ≤ 2: with the augmented joint prior
M̃ = [[P̄, −x̄, P̄Hᵀ], [HP̄, z̄, S]] (S = HP̄Hᵀ + R) and G = S⁻¹ M̃_bottom = [Kᵀ, S⁻¹z̄, I],

    L M̃ = M̃_top − P̄Hᵀ G,    [P⁺ | −x⁺] = (L M̃)_left − (L M̃)_right G_left,

which is the Joseph form P⁺ = (I − KH) P̄ (I − KH)ᵀ + K R Kᵀ evaluated as a congruence of
the positive semi-definite M (so P⁺ stays PSD for any gain, and a gain error enters at second
order). The chi-square z̄ᵀS⁻¹z̄ (Lubey & Ely 2022 eq. 6) comes from the same G; a filter that
does not process the measurement, or whose chi-square exceeds its gate, keeps x̄ and P̄.
S⁻¹ is 1/S for m = 1 and the adjugate over the determinant for m = 2.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir

configure_cache_dir()


@njit("void(float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, ::1], "
      "boolean[::1], float64[::1], float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[::1], "
      "boolean[::1])", cache=True)
def joseph_update(x, P, H, R, residual, does, gate, x_out, P_out, S_out, chi2_out, processed_out):
    """x (N, n), P (N, n, n), H (N, m, n), R (N, m, m), z̄ (N, m) → x⁺, P⁺ (not symmetrised),
    S (N, m, m), chi-square (N,) and which filters updated; ``does`` (N,) which filters process
    the measurement, ``gate`` (N,) their chi-square thresholds (inf: no editing). m is 1 or 2."""
    N, n, _ = P.shape
    m = H.shape[1]
    PHt = np.empty((n, m))
    HP = np.empty((m, n))
    G = np.empty((m, n + 1 + m))
    Sinv = np.empty((m, m))
    LM = np.empty((n, n + 1 + m))
    for i in range(N):
        for a in range(n):
            for j in range(m):
                acc = 0.0
                for k in range(n):
                    acc += P[i, a, k] * H[i, j, k]
                PHt[a, j] = acc
        for j in range(m):
            for a in range(n):
                acc = 0.0
                for k in range(n):
                    acc += H[i, j, k] * P[i, k, a]
                HP[j, a] = acc
        for j in range(m):
            for l in range(m):
                acc = 0.0
                for k in range(n):
                    acc += HP[j, k] * H[i, l, k]
                S_out[i, j, l] = acc + R[i, j, l]
        if m == 1:
            Sinv[0, 0] = 1.0 / S_out[i, 0, 0]
        else:
            a_, b_, c_, d_ = S_out[i, 0, 0], S_out[i, 0, 1], S_out[i, 1, 0], S_out[i, 1, 1]
            det = a_ * d_ + b_ * (-c_)  # first row · adjugate's first column
            Sinv[0, 0], Sinv[0, 1], Sinv[1, 0], Sinv[1, 1] = d_ / det, -b_ / det, -c_ / det, a_ / det
        # G = S⁻¹ [HP̄, z̄, S]
        for j in range(m):
            for c in range(n + 1 + m):
                acc = 0.0
                for l in range(m):
                    if c < n:
                        b = HP[l, c]
                    elif c == n:
                        b = residual[i, l]
                    else:
                        b = S_out[i, l, c - n - 1]
                    acc += Sinv[j, l] * b
                G[j, c] = acc
        chi2 = 0.0
        for j in range(m):
            chi2 += residual[i, j] * G[j, n]
        chi2_out[i] = chi2
        ok = does[i] and (gate[i] == np.inf or chi2 <= gate[i])
        processed_out[i] = ok
        if not ok:
            for a in range(n):
                x_out[i, a] = x[i, a]
                for c in range(n):
                    P_out[i, a, c] = P[i, a, c]
            continue
        # L M̃ (first n rows): M̃_top − P̄Hᵀ G
        for a in range(n):
            for c in range(n + 1 + m):
                if c < n:
                    top = P[i, a, c]
                elif c == n:
                    top = -x[i, a]
                else:
                    top = PHt[a, c - n - 1]
                acc = 0.0
                for j in range(m):
                    acc += PHt[a, j] * G[j, c]
                LM[a, c] = top - acc
        # [P⁺ | −x⁺] = (L M̃)_left − (L M̃)_right G_left
        for a in range(n):
            for c in range(n + 1):
                acc = 0.0
                for j in range(m):
                    acc += LM[a, n + 1 + j] * G[j, c]
                v = LM[a, c] - acc
                if c < n:
                    P_out[i, a, c] = v
                else:
                    x_out[i, a] = -v

"""Compiled kernel: one-way Doppler h and H from the light-time solutions at both ends of the count.

Lubey & Ely 2022 §4.1 (model in :mod:`fsw.models.radiometric`): over the count interval T ending
at the time tag,

    h = (ρ_g(end) − ρ_g(start))/T + c (f − a T/2),

    ∂h/∂[r, v, q] = ([k u, −δ k u, 0]_end − [k u, −δ k u]_start Yb)/T,
    ∂h/∂δ = (∂ρ/∂δ_end − ∂ρ/∂δ_start)/T,   ∂h/∂f = c,   ∂h/∂a = −c T/2,

with Yb = ∂[r, v](t − T)/∂[r, v, q](t) the backward sensitivity of the count's start
(:mod:`fsw.kernels.count_start`); the [r, v, q] columns map onto the state's columns
(several parameter states may drive one q).
"""

from __future__ import annotations

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit("void(float64[:, ::1], float64[:, :, ::1], float64[:, ::1], float64[::1], float64[:, :, ::1], "
      "int64[::1], float64[:, :], float64, int64, int64, float64, float64[:, ::1], float64[:, :, ::1])",
      cache=True)
def doppler_prediction(rho, ku, d_rho_d_delta, delta, Yb, src, x, count_s, c0, c1, c_km_s, h, H):
    """h (N, 1), H (N, 1, n) from ρ, k u, ∂ρ/∂δ at [end, start] ((2, N), (2, N, 3), (2, N)),
    the clock phase δ (N,), Yb (N, 6, 6 + n_q), ``src`` (n,) the [r, v, q] column feeding each
    state column (−1: none) and the states x (N, n), whose clock block [c0, c1) holds phase,
    frequency f and drift a (absent components: 0)."""
    N = rho.shape[1]
    n = src.shape[0]
    for i in range(N):
        freq = x[i, c0 + 1] if c1 - c0 > 1 else 0.0
        drift = x[i, c0 + 2] if c1 - c0 > 2 else 0.0
        h[i, 0] = (rho[0, i] - rho[1, i]) / count_s + c_km_s * (freq - 0.5 * drift * count_s)
        d0 = -delta[i]
        for col in range(n):
            j = src[col]
            if j < 0:
                H[i, 0, col] = 0.0
                continue
            start = 0.0
            for k in range(3):
                start += ku[1, i, k] * Yb[i, k, j] + (d0 * ku[1, i, k]) * Yb[i, k + 3, j]
            end = 0.0
            if j < 3:
                end = ku[0, i, j]
            elif j < 6:
                end = d0 * ku[0, i, j - 3]
            H[i, 0, col] = (end - start) / count_s
        if c1 > c0:
            H[i, 0, c0] = (d_rho_d_delta[0, i] - d_rho_d_delta[1, i]) / count_s
            if c1 - c0 > 1:
                H[i, 0, c0 + 1] = c_km_s
            if c1 - c0 > 2:
                H[i, 0, c0 + 2] = -0.5 * c_km_s * count_s

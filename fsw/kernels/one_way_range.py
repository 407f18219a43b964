"""Compiled kernel: one-way range h and H from the light-time solution at the reception epoch.

Lubey & Ely 2022 §4.1 (model in :mod:`fsw.models.radiometric`): the pseudo-range compares the
reception clock reading with the transmit time,

    h = ρ_g + c δ (+ b),

    ∂h/∂r = k u,   ∂h/∂v = −δ k u,   ∂h/∂δ = c + ∂ρ_g/∂δ,   ∂h/∂b = 1,

with δ the clock phase and b the range bias, where the states carry them.
"""

from __future__ import annotations

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit("void(float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, ::1], float64[::1], float64[:, :], "
      "boolean, int64, int64, float64, float64[:, ::1], float64[:, :, ::1])", cache=True)
def range_prediction(rho, ku, d_rho_d_v, d_rho_d_delta, delta, x, has_clock, c0, bias, c_km_s, h, H):
    """h (N, 1) and H (N, 1, n) from ρ, k u, −δ k u (1, N, 3) and ∂ρ_g/∂δ at the one reception epoch
    ((1, N), ...), the clock phase δ (N,) and the states x (N, n); ``has_clock``: the states have a
    clock, its phase in column c0; ``bias``: the range-bias column (−1: none)."""
    n = H.shape[2]
    for i in range(x.shape[0]):
        for col in range(n):
            H[i, 0, col] = 0.0
        for j in range(3):
            H[i, 0, j] = ku[0, i, j]
            H[i, 0, 3 + j] = d_rho_d_v[0, i, j]
        v = rho[0, i] + c_km_s * delta[i]
        if has_clock:
            H[i, 0, c0] = c_km_s + d_rho_d_delta[0, i]
        if bias >= 0:
            v = v + x[i, bias]
            H[i, 0, bias] = 1.0
        h[i, 0] = v

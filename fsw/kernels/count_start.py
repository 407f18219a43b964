"""Compiled kernel: a Doppler count's start state from the last propagation leg's STM.

Over a leg from t − T to t the sensitivity [Φ | Ψ] = ∂z(t)/∂[z(t − T), q] maps start to end.
Φ is symplectic (a Hamiltonian flow: the gravity gradient G is symmetric), so

    Φ⁻¹ = [[Φ_vvᵀ, −Φ_rvᵀ], [−Φ_vrᵀ, Φ_rrᵀ]],    Yb = ∂z(t − T)/∂[z(t), q] = [Φ⁻¹, −Φ⁻¹Ψ],

and a change dz = [z(t) − z₁, q − q_leg] of the state at t since the leg was flown (a
measurement update at t) carries to the start as z(t − T) = z₀ + Yb dz
(:meth:`fsw.filters.ekf.EKFStack.count_start`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit("void(float64[:, :, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], "
      "float64[:, ::1], float64[:, ::1], float64[:, :, ::1])", cache=True)
def count_start_from_leg(Y, z0, z1, z, q, q_leg, z_start, Yb):
    """z_start (N, 6) and Yb (N, 6, 6 + n_q) from the leg's Y (N, 6, 6 + n_q), its start and end
    states z0, z1 (N, 6) and drivers q_leg, for the current state z (N, 6) and drivers q."""
    N, _, m = Y.shape
    inv = np.empty((6, 6))
    dz = np.empty(m)
    for i in range(N):
        for a in range(3):
            for b in range(3):
                inv[a, b] = Y[i, b + 3, a + 3]
                inv[a, b + 3] = -Y[i, b, a + 3]
                inv[a + 3, b] = -Y[i, b + 3, a]
                inv[a + 3, b + 3] = Y[i, b, a]
        for a in range(6):
            for b in range(6):
                Yb[i, a, b] = inv[a, b]
            for c in range(6, m):
                acc = 0.0
                for k in range(6):
                    acc += inv[a, k] * Y[i, k, c]
                Yb[i, a, c] = -acc
        for a in range(6):
            dz[a] = z[i, a] - z1[i, a]
        for c in range(6, m):
            dz[c] = q[i, c - 6] - q_leg[i, c - 6]
        for a in range(6):
            acc = 0.0
            for c in range(m):
                acc += Yb[i, a, c] * dz[c]
            z_start[i, a] = z0[i, a] + acc

"""Compiled kernel: the EKF time update x ← Φ(x), P ← sym(Φ P Φᵀ + Q) of N filters, by Φ's blocks.

Φ over the bank's union state (:meth:`fsw.filters.ekf.EKFStack.transition`) has three kinds of
rows: the six dynamics rows [Y_z | Y_q mapped onto the parameter columns] (Y the variational
equations' sensitivity), the clock block Φ_c = [[1, h, h²/2], [0, 1, h], [0, 0, 1]] and
identity rows for the other parameters. Φ P Φᵀ is formed by those blocks (the dense product
of two n × n matrices costs 2n³ per filter; by blocks, the identity rows cost a copy).

Q: the clock's exact discrete process noise (:mod:`fsw.models.clock`)

    Q11 = q1 h + q2 h³/3 + q3 h⁵/20   Q12 = q2 h²/2 + q3 h⁴/8   Q13 = q3 h³/6
    Q22 = q2 h + q3 h³/3               Q23 = q3 h²/2              Q33 = q3 h

and the white acceleration noise on the velocity (SNC: Q_rr = q h³/3, Q_rv = q h²/2,
Q_vv = q h). The result is symmetrised, (M + Mᵀ)/2, so the rounding asymmetry of the products
never accumulates.

The state: [r, v] is the propagated trajectory, the clock block steps by Φ_c, the other
parameters are constant over the interval.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit(cache=True)
def _phi_rows(i, Y, src, c0, c1, h, rows):
    """Φ of filter i into ``rows`` (n, n), written element by element (a row view per row cost
    more than the row's arithmetic)."""
    n = rows.shape[0]
    for r in range(n):
        for col in range(n):
            rows[r, col] = 0.0
    for r in range(6):
        for col in range(n):
            j = src[col]
            if j >= 0:
                rows[r, col] = Y[i, r, j]
    for r in range(6, n):
        rows[r, r] = 1.0
        if c0 <= r < c1:
            k = r - c0
            if k + 1 < c1 - c0:
                rows[r, r + 1] = h
            if k + 2 < c1 - c0:
                rows[r, r + 2] = 0.5 * h * h


@njit("void(float64[:, ::1], float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], int64[::1], int64, int64, "
      "float64, float64[:, ::1], float64[::1], float64[:, ::1], float64[:, :, ::1])", cache=True)
def time_update(x, z1, P, Y, src, c0, c1, h, clock_q, snc, x_out, out):
    """x_out = [z1, Φ(x) of the parameters] and out = sym(Φ P Φᵀ + Q) for x (N, n), the
    propagated [r, v] z1 (N, 6), P (N, n, n) and Y (N, 6, 6 + n_q); ``src`` (n,) gives the
    column of Y that feeds each state column of the dynamics rows (−1: none); the clock block
    is [c0, c1) (c0 = c1: no clock); ``clock_q`` (N, 3) the clock's q1, q2, q3, ``snc`` (N,)
    the SNC spectral density."""
    N, n, _ = P.shape
    for i in range(N):
        for a in range(n):
            x_out[i, a] = z1[i, a] if a < 6 else x[i, a]
        k = c1 - c0
        if k > 1:  # phase += h f (+ h²/2 a), frequency += h a
            x_out[i, c0] = x[i, c0] + h * x[i, c0 + 1] + (0.5 * h * h * x[i, c0 + 2] if k > 2 else 0.0)
            if k > 2:
                x_out[i, c0 + 1] = x[i, c0 + 1] + h * x[i, c0 + 2]
    A = np.empty((n, n))  # Φ P
    rows = np.empty((n, n))  # Φ, row by row
    nz = np.empty((n, n), dtype=np.int64)  # the columns of Φ's non-zero entries, row by row
    nzc = np.empty(n, dtype=np.int64)
    At = np.empty((n, n))  # (Φ P)ᵀ
    acc = np.empty(n)
    for i in range(N):
        _phi_rows(i, Y, src, c0, c1, h, rows)
        for r in range(n):
            if r < 6 or c0 <= r < c1:
                for c in range(n):
                    A[r, c] = 0.0
                for k in range(n):
                    f = rows[r, k]
                    if f != 0.0:
                        for c in range(n):
                            A[r, c] += f * P[i, k, c]
            else:
                for c in range(n):
                    A[r, c] = P[i, r, c]
        # (Φ P) Φᵀ over the non-zero entries of Φ's rows only, in the same order as the full sum
        # (the skipped terms are exact zeros, as in Φ P above)
        for s in range(n):
            m = 0
            for k in range(n):
                if rows[s, k] != 0.0:
                    nz[s, m] = k
                    m += 1
            nzc[s] = m
        # every out[r, s] accumulates its terms in the same order as the plain row-by-row sum;
        # running all r together (over Aᵀ's contiguous rows) lets the loop vectorise
        for r in range(n):
            for k in range(n):
                At[k, r] = A[r, k]
        for s in range(n):
            if s < 6 or c0 <= s < c1:
                for r in range(n):
                    acc[r] = 0.0
                for j in range(nzc[s]):
                    k = nz[s, j]
                    f = rows[s, k]
                    for r in range(n):
                        acc[r] += At[k, r] * f
                for r in range(n):
                    out[i, r, s] = acc[r]
            else:
                for r in range(n):
                    out[i, r, s] = A[r, s]
        dt = abs(h)
        if c1 > c0:
            q1, q2, q3 = clock_q[i, 0], clock_q[i, 1], clock_q[i, 2]
            h2 = dt * dt
            h3 = h2 * dt
            Q = np.empty((3, 3))
            Q[0, 0] = q1 * dt + q2 * (h3 / 3.0) + q3 * (h3 * h2 / 20.0)
            Q[0, 1] = q2 * (h2 / 2.0) + q3 * (h2 * h2 / 8.0)
            Q[0, 2] = q3 * (h3 / 6.0)
            Q[1, 1] = q2 * dt + q3 * (h3 / 3.0)
            Q[1, 2] = q3 * (h2 / 2.0)
            Q[2, 2] = q3 * dt
            Q[1, 0], Q[2, 0], Q[2, 1] = Q[0, 1], Q[0, 2], Q[1, 2]
            for a in range(c1 - c0):
                for b in range(c1 - c0):
                    out[i, c0 + a, c0 + b] += Q[a, b]
        q = snc[i]
        if q != 0.0:
            for a in range(3):
                out[i, a, a] += q * dt ** 3 / 3.0
                out[i, a, a + 3] += q * dt ** 2 / 2.0
                out[i, a + 3, a] += q * dt ** 2 / 2.0
                out[i, a + 3, a + 3] += q * dt
        for r in range(n):
            for s in range(r + 1, n):
                m = 0.5 * (out[i, r, s] + out[i, s, r])
                out[i, r, s] = m
                out[i, s, r] = m

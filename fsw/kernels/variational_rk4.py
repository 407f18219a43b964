"""Compiled kernel: RK4 of the trajectory and its variational equations for N filters at once.

The arithmetic of :class:`fsw.models.propagator.Propagator` (whose docstring states the model
and the step rule), as one compiled loop over the steps of a propagation interval:

    ż = [v, a(r, q, t)],    Ẏ_r = Y_v,    Ẏ_v = G Y_r + [0 | ∂a/∂q],

classical RK4 with h = min(max_step, κ min_i √(r_i² min(r_i/μ, 1/v_i²))) (steps evened out
to the interval's end), the forces of :mod:`fsw.models.forces` (four 1/d² centres, the
indirect third-body term, the ACS small force in the cruise frame at the first filter, the
batched polynomial), and where |G| h² (h|v|/|r| + 1e-4) is below ``frozen_tol`` the
closed-form frozen-gradient STM (Φ = I + hA + (hA)²/2 + (hA)³/6 + (hA)⁴/24 with G at mid-step,
Ψ with RK4's weights of the forcing). The third bodies come from the ephemeris table's cubic
Hermite interpolant (:meth:`fsw.astro.ephemeris.EphemerisTable.positions`) evaluated here.

Every helper is in this module (a cached kernel is not recompiled when an njit helper in
another module changes).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()

_SUN, _EMB, _JUPITER, _MARS = 0, 1, 2, 4


@njit("void(float64, float64[:, :, ::1], float64[:, :, ::1], float64, float64, float64[::1], float64[:, ::1], float64[::1])",
      cache=True)
def third_body_epoch(t, tab_p, tab_v, tab_t0, tab_step, gm, b, indirect):
    """The four 1/d² centres b (4, 3) (Mars' centre, Sun, EMB, Jupiter, Mars-centred) and the
    indirect acceleration −Σ μ_k r_k/|r_k|³ (3,) at t, from the table's Hermite interpolant
    p(s) = (2s³ − 3s² + 1) p_i + (s³ − 2s² + s) h v_i + (3s² − 2s³) p_i+1 + (s³ − s²) h v_i+1."""
    x = (t - tab_t0) / tab_step
    i = min(int(x), tab_p.shape[0] - 2)
    s = x - i
    s2 = s * s
    s3 = s2 * s
    h = tab_step
    c0 = 2 * s3 - 3 * s2 + 1
    c1 = (s3 - 2 * s2 + s) * h
    c2 = -2 * s3 + 3 * s2
    c3 = (s3 - s2) * h
    mars = np.empty(3)
    for j in range(3):
        mars[j] = c0 * tab_p[i, _MARS, j] + c1 * tab_v[i, _MARS, j] + c2 * tab_p[i + 1, _MARS, j] + c3 * tab_v[i + 1, _MARS, j]
        b[0, j] = 0.0
        indirect[j] = 0.0
    for k in range(3):
        rk2 = 0.0
        for j in range(3):
            p = c0 * tab_p[i, k, j] + c1 * tab_v[i, k, j] + c2 * tab_p[i + 1, k, j] + c3 * tab_v[i + 1, k, j]
            b[k + 1, j] = p - mars[j]
            rk2 += b[k + 1, j] * b[k + 1, j]
        f = gm[k + 1] / (rk2 * math.sqrt(rk2))
        for j in range(3):
            indirect[j] -= f * b[k + 1, j]


@njit(cache=True)
def _acs(r0, b, q, acs_nominal, acs_body, a_acs, part):
    """ACS acceleration (N, 3) and its partials w.r.t. q_acs, θ₁, θ₂ (N, 3, 3) in the cruise
    frame (z to the Sun, x the Earth direction across it) at the first filter's position r0."""
    zx, zy, zz = b[1, 0] - r0[0], b[1, 1] - r0[1], b[1, 2] - r0[2]
    n = math.sqrt(zx * zx + zy * zy + zz * zz)
    zx, zy, zz = zx / n, zy / n, zz / n
    ex, ey, ez = b[2, 0] - r0[0], b[2, 1] - r0[1], b[2, 2] - r0[2]
    p = ex * zx + ey * zy + ez * zz
    xx, xy, xz = ex - p * zx, ey - p * zy, ez - p * zz
    n = math.sqrt(xx * xx + xy * xy + xz * xz)
    xx, xy, xz = xx / n, xy / n, xz / n
    C = np.empty((3, 3))
    C[0, 0], C[0, 1], C[0, 2] = xx, xy, xz
    C[1, 0], C[1, 1], C[1, 2] = zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx
    C[2, 0], C[2, 1], C[2, 2] = zx, zy, zz
    N = q.shape[0]
    Cb = np.empty((3, 3))
    for i in range(N):
        for row in range(3):
            for j in range(3):
                Cb[row, j] = acs_body[i, row, 0] * C[0, j] + acs_body[i, row, 1] * C[1, j] + acs_body[i, row, 2] * C[2, j]
        a_nom = acs_nominal[i]
        gain = a_nom * (1.0 + q[i, 1])
        for j in range(3):
            u = Cb[0, j] + q[i, 2] * Cb[1, j] + q[i, 3] * Cb[2, j]
            part[i, j, 0] = a_nom * u
            part[i, j, 1] = gain * Cb[1, j]
            part[i, j, 2] = gain * Cb[2, j]
            a_acs[i, j] = gain * u


@njit(cache=True)
def _stage(X, b, extra, coeff, powers, q, deg, kz, d, d2, w):
    """One RK4 stage of the state: kz = [v, Σ_k c_k d_k/|d_k|³ + extra + Σ_k s^k c_poly,k], and
    the stage's d (N, 4, 3), |d|² (N, 4), c/|d|³ (N, 4) for the partials."""
    N = X.shape[0]
    for i in range(N):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for k in range(4):
            dx = X[i, 0] - b[k, 0]
            dy = X[i, 1] - b[k, 1]
            dz = X[i, 2] - b[k, 2]
            dd = dx * dx + dy * dy + dz * dz
            wk = coeff[i, k] / (dd * math.sqrt(dd))
            d[i, k, 0], d[i, k, 1], d[i, k, 2] = dx, dy, dz
            d2[i, k] = dd
            w[i, k] = wk
            a0 += wk * dx
            a1 += wk * dy
            a2 += wk * dz
        a0 += extra[i, 0]
        a1 += extra[i, 1]
        a2 += extra[i, 2]
        for k in range(deg + 1):
            pk = powers[i, k]
            a0 += pk * q[i, 4 + 3 * k]
            a1 += pk * q[i, 5 + 3 * k]
            a2 += pk * q[i, 6 + 3 * k]
        kz[i, 0], kz[i, 1], kz[i, 2] = X[i, 3], X[i, 4], X[i, 5]
        kz[i, 3], kz[i, 4], kz[i, 5] = a0, a1, a2


@njit(cache=True)
def _gradient(d, d2, w, G):
    """G = Σ_k c_k (I/|d_k|³ − 3 d_k d_kᵀ/|d_k|⁵) (N, 3, 3)."""
    N = d.shape[0]
    for i in range(N):
        ws = w[i, 0] + w[i, 1] + w[i, 2] + w[i, 3]
        for a in range(3):
            for c in range(3):
                g = 0.0
                for k in range(4):
                    g += (-3.0 * w[i, k] / d2[i, k]) * d[i, k, a] * d[i, k, c]
                G[i, a, c] = g + ws if a == c else g


@njit(cache=True)
def _forcing(d, d2, srp, part, powers, deg, B):
    """∂a/∂q (N, 3, n_q): the SRP column from the stage's Sun vector, the ACS columns, s^k e_j."""
    N = d.shape[0]
    B[:] = 0.0
    for i in range(N):
        f = srp[i] / (d2[i, 1] * math.sqrt(d2[i, 1]))
        for j in range(3):
            B[i, j, 0] = f * d[i, 1, j]
            B[i, j, 1] = part[i, j, 0]
            B[i, j, 2] = part[i, j, 1]
            B[i, j, 3] = part[i, j, 2]
        for k in range(deg + 1):
            for j in range(3):
                B[i, j, 4 + 3 * k + j] = powers[i, k]


@njit(cache=True)
def _frozen_gradient_step(Y, h, G, B0, Bm, B1):
    """Y ← [Φ Y_z | Φ Y_q + Ψ], Φ = I + hA + … + (hA)⁴/24 with A = [[0, I], [G, 0]] and
    Ψ_r = h²/6 (B₀ + 2B_m) + h⁴/24 G B_m, Ψ_v = h/6 (B₀ + 4B_m + B₁) + h³/6 G B_m."""
    N, _, m = Y.shape
    h2 = h * h
    Phi = np.empty((6, 6))
    out = np.empty((6, m))
    for i in range(N):
        for a in range(3):
            for c in range(3):
                g2 = G[i, a, 0] * G[i, 0, c] + G[i, a, 1] * G[i, 1, c] + G[i, a, 2] * G[i, 2, c]
                diag = (0.5 * h2) * G[i, a, c] + (h2 * h2 / 24.0) * g2
                eye = 1.0 if a == c else 0.0
                Phi[a, c] = diag + eye
                Phi[a + 3, c + 3] = diag + eye
                Phi[a, c + 3] = (h2 * h / 6.0) * G[i, a, c] + h * eye
                Phi[a + 3, c] = h * G[i, a, c] + (h2 * h / 6.0) * g2
        for a in range(6):
            for c in range(m):
                s = 0.0
                for k in range(6):
                    s += Phi[a, k] * Y[i, k, c]
                out[a, c] = s
        for a in range(3):
            for c in range(6, m):
                gb = G[i, a, 0] * Bm[i, 0, c - 6] + G[i, a, 1] * Bm[i, 1, c - 6] + G[i, a, 2] * Bm[i, 2, c - 6]
                out[a, c] += (h2 / 6.0) * (B0[i, a, c - 6] + 2.0 * Bm[i, a, c - 6]) + (h2 * h2 / 24.0) * gb
                out[a + 3, c] += ((h / 6.0) * (B0[i, a, c - 6] + 4.0 * Bm[i, a, c - 6] + B1[i, a, c - 6])
                                  + (h2 * h / 6.0) * gb)
        for a in range(6):
            for c in range(m):
                Y[i, a, c] = out[a, c]


@njit("int64(float64, float64, float64[:, ::1], float64[:, ::1], boolean, float64[::1], float64[::1], "
      "float64[:, :, ::1], int64, float64[::1], float64, float64, float64, float64, float64[:, :, ::1], "
      "float64[:, :, ::1], float64, float64, float64[::1], float64[:, :, ::1])", cache=True)
def rk4_variational(t0, t1, z, q, with_stm, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin,
                    kappa, max_step, frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm, Y):
    """Propagate z = [r, v] (N, 6) in place from t0 to t1 (either direction) with drivers q
    (N, n_q), and write Y = ∂z(t1)/∂[z(t0), q] (N, 6, 6 + n_q) (starting from [I | 0]);
    ``deg`` −1 without the polynomial; ``gm`` [μ_Mars, μ_Sun, μ_EMB, μ_Jupiter]. Returns the
    number of steps taken."""
    N = z.shape[0]
    nq = q.shape[1]
    m = 6 + nq
    Y[:] = 0.0
    for i in range(N):
        for j in range(6):
            Y[i, j, j] = 1.0
    total = t1 - t0
    if total == 0.0:
        return 0
    direction = 1.0 if total > 0 else -1.0
    coeff = np.empty((N, 4))
    for i in range(N):
        coeff[i, 0] = -gm[0]
        coeff[i, 1] = -gm[1] + (1.0 + q[i, 0]) * srp[i]
        coeff[i, 2] = -gm[2]
        coeff[i, 3] = -gm[3]
    t_batch = np.empty(N)
    if deg >= 0:
        tm = t0 + 0.5 * total
        for i in range(N):
            T = poly_batch[i]
            t_batch[i] = poly_origin + math.floor((tm - poly_origin) / T) * T
    powers = np.zeros((N, max(deg + 1, 1)))
    b0 = np.empty((4, 3))
    bm = np.empty((4, 3))
    b1 = np.empty((4, 3))
    ind0 = np.empty(3)
    indm = np.empty(3)
    ind1 = np.empty(3)
    a_acs = np.empty((N, 3))
    part = np.empty((N, 3, 3))
    extra = np.empty((N, 3))
    kz = np.empty((4, N, 6))
    X = np.empty((N, 6))
    d = np.empty((N, 4, 3))
    d2 = np.empty((N, 4))
    w = np.empty((N, 4))
    G = np.empty((N, 3, 3))
    kY = np.empty((4, N, 6, m))
    XY = np.empty((N, 6, m))
    Bs = np.empty((3, N, 3, nq))
    cs = (0.0, 0.5, 0.5, 1.0)
    steps = 0
    t = t0
    while True:
        remaining = t1 - t
        if remaining * direction <= 1e-9:
            break
        scale = math.inf
        for i in range(N):
            r2 = z[i, 0] * z[i, 0] + z[i, 1] * z[i, 1] + z[i, 2] * z[i, 2]
            v2 = z[i, 3] * z[i, 3] + z[i, 4] * z[i, 4] + z[i, 5] * z[i, 5]
            scale = min(scale, r2 * min(math.sqrt(r2) / gm[0], 1.0 / max(v2, 1e-18)))
        h = min(max_step, kappa * math.sqrt(scale))
        if abs(remaining) <= h * 1.000001:
            h = abs(remaining)
        else:
            # even out the steps left so the last one is not a sliver
            h = abs(remaining) / math.ceil(abs(remaining) / h)
        h *= direction
        t_mid = t + 0.5 * h
        t_end = t1 if abs(t1 - (t + h)) < 1e-9 else t + h
        third_body_epoch(t, tab_p, tab_v, tab_t0, tab_step, gm, b0, ind0)
        third_body_epoch(t_mid, tab_p, tab_v, tab_t0, tab_step, gm, bm, indm)
        third_body_epoch(t_end, tab_p, tab_v, tab_t0, tab_step, gm, b1, ind1)
        # the cruise frame turns by < 1e-5 rad per step: one ACS evaluation per step
        _acs(z[0], bm, q, acs_nominal, acs_body, a_acs, part)
        full = False
        for s in range(4):
            c = cs[s]
            if s == 0:
                tk, b, ind = t, b0, ind0
            elif s == 3:
                tk, b, ind = t_end, b1, ind1
            else:
                tk, b, ind = t_mid, bm, indm
            for i in range(N):
                for j in range(6):
                    X[i, j] = z[i, j] if s == 0 else z[i, j] + (c * h) * kz[s - 1, i, j]
                for j in range(3):
                    extra[i, j] = ind[j] + a_acs[i, j]
                if deg >= 0:
                    sp = (tk - t_batch[i]) / poly_batch[i]
                    pk = 1.0
                    for k in range(deg + 1):
                        powers[i, k] = pk
                        pk *= sp
            _stage(X, b, extra, coeff, powers, q, deg, kz[s], d, d2, w)
            if not with_stm:
                continue
            if s == 0:
                # |G| ≤ 2 Σ|c_k|/|d_k|³, first filter (the others differ by < 1 %)
                g_max = 2.0 * (abs(w[0, 0]) + abs(w[0, 1]) + abs(w[0, 2]) + abs(w[0, 3]))
                r2 = z[0, 0] * z[0, 0] + z[0, 1] * z[0, 1] + z[0, 2] * z[0, 2]
                v2 = z[0, 3] * z[0, 3] + z[0, 4] * z[0, 4] + z[0, 5] * z[0, 5]
                turn = abs(h) * math.sqrt(v2 / r2)
                full = g_max * h * h * (turn + 1e-4) >= frozen_tol
            if full:
                _gradient(d, d2, w, G)
                _forcing(d, d2, srp, part, powers, deg, Bs[0])
                for i in range(N):
                    for a in range(6):
                        for cc in range(m):
                            XY[i, a, cc] = Y[i, a, cc] if s == 0 else Y[i, a, cc] + (c * h) * kY[s - 1, i, a, cc]
                    for a in range(3):
                        for cc in range(m):
                            kY[s, i, a, cc] = XY[i, a + 3, cc]
                            kY[s, i, a + 3, cc] = (G[i, a, 0] * XY[i, 0, cc] + G[i, a, 1] * XY[i, 1, cc]
                                                   + G[i, a, 2] * XY[i, 2, cc])
                        for cc in range(nq):
                            kY[s, i, a + 3, 6 + cc] += Bs[0, i, a, cc]
            else:
                # the forcing at the stages RK4 weights it with (start, middle, end)
                if s == 1:
                    _gradient(d, d2, w, G)
                if s != 2:
                    _forcing(d, d2, srp, part, powers, deg, Bs[0 if s == 0 else (1 if s == 1 else 2)])
        for i in range(N):
            for j in range(6):
                z[i, j] = z[i, j] + (h / 6.0) * (kz[0, i, j] + 2.0 * (kz[1, i, j] + kz[2, i, j]) + kz[3, i, j])
        if with_stm:
            if full:
                for i in range(N):
                    for a in range(6):
                        for cc in range(m):
                            Y[i, a, cc] = Y[i, a, cc] + (h / 6.0) * (
                                kY[0, i, a, cc] + 2.0 * (kY[1, i, a, cc] + kY[2, i, a, cc]) + kY[3, i, a, cc])
            else:
                _frozen_gradient_step(Y, h, G, Bs[0], Bs[1], Bs[2])
        t = t_end
        steps += 1
    return steps

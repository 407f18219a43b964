"""Compiled kernel: B-plane targeting of one state and its complex-step Jacobian.

The formulas of :mod:`fsw.models.bplane` (which derives them: Kizner 1961, Vallado §12.4) —
energy, angular momentum, eccentricity vector, the incoming asymptote Ŝ, B = b (Ŝ × ĥ), T̂ and R̂
from the Mars pole, the hyperbolic anomaly and the time to closest approach — in the same order
of operations, on scalars: once on the real state for the values, and once per column on the
state with the complex step i·h·eₖ for the Jacobian (Squire & Trapp 1998: every operation is
analytic, so Im f(x + i h eₖ)/h is the k-th column to rounding). ``np.sqrt`` and ``np.arcsinh``
serve the real and the complex evaluation alike.

The compiled square roots and inverse hyperbolic sine are not numpy's vectorised ones:
``tests/test_bplane.py`` holds the values to the numpy form within 1e-13 relative and the
Jacobian to the numpy form's complex step within 1e-11 (on the default run: B·R and B·T to the
bit, their covariance within 9e-13).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources
from fsw.kernels.codes import BPLANE_DEGENERATE, BPLANE_OK

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit(cache=True)
def _dot(a0, a1, a2, b0, b1, b2):
    # no conjugation: the complex step needs the analytic continuation of a·b
    return a0 * b0 + a1 * b1 + a2 * b2


@njit(cache=True)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True)
def _values(r0, r1, r2, v0, v1, v2, mu, k0, k1, k2):
    """(B·R, B·T, t_p − t, v∞, |h|, |Ŝ × k̂|, e) of the state (real or complex); the last three
    for the caller's checks of a degenerate geometry."""
    rmag = np.sqrt(_dot(r0, r1, r2, r0, r1, r2))
    v2_ = _dot(v0, v1, v2, v0, v1, v2)
    energy = v2_ / 2.0 - mu / rmag
    a = -mu / (2.0 * energy)
    h0, h1, h2 = _cross(r0, r1, r2, v0, v1, v2)
    rv = _dot(r0, r1, r2, v0, v1, v2)
    c = v2_ - mu / rmag
    e0, e1, e2 = (c * r0 - rv * v0) / mu, (c * r1 - rv * v1) / mu, (c * r2 - rv * v2) / mu
    e = np.sqrt(_dot(e0, e1, e2, e0, e1, e2))
    hmag = np.sqrt(_dot(h0, h1, h2, h0, h1, h2))
    eh0, eh1, eh2 = e0 / e, e1 / e, e2 / e
    hh0, hh1, hh2 = h0 / hmag, h1 / hmag, h2 / hmag
    w = np.sqrt(e * e - 1.0) / e
    x0, x1, x2 = _cross(hh0, hh1, hh2, eh0, eh1, eh2)
    s0, s1, s2 = eh0 / e + w * x0, eh1 / e + w * x1, eh2 / e + w * x2
    b = -a * np.sqrt(e * e - 1.0)
    c0, c1, c2 = _cross(s0, s1, s2, hh0, hh1, hh2)
    bv0, bv1, bv2 = b * c0, b * c1, b * c2
    sk0, sk1, sk2 = _cross(s0, s1, s2, k0, k1, k2)
    skmag = np.sqrt(_dot(sk0, sk1, sk2, sk0, sk1, sk2))
    t0, t1, t2 = sk0 / skmag, sk1 / skmag, sk2 / skmag
    q0, q1, q2 = _cross(s0, s1, s2, t0, t1, t2)
    sinh_f = rv / (e * np.sqrt(-mu * a))
    f = np.arcsinh(sinh_f)
    n = np.sqrt(mu / (-a) ** 3)
    return (_dot(bv0, bv1, bv2, q0, q1, q2), _dot(bv0, bv1, bv2, t0, t1, t2), -(e * sinh_f - f) / n,
            np.sqrt(2.0 * energy), hmag, skmag, e)


@njit("int64(float64[::1], float64, float64[::1], float64[::1], float64[:, ::1])", cache=True)
def bplane_complex_step(x, mu, pole, values, jac):
    """x = [r, v] (6,) Mars-centred, μ and the pole k̂ (3,) → ``values`` (B·R, B·T, t_p − t, v∞)
    and ``jac`` ∂(B·R, B·T, t_p − t)/∂(r, v) (3, 6). Returns ``BPLANE_OK``, or
    ``BPLANE_DEGENERATE`` (outputs unspecified) for a non-finite state, one that is not on a
    hyperbola (energy ≤ 0, e ≤ 1), a radial one (h = 0), an asymptote along the pole, or any
    non-finite result. A division by an exact zero on the way (e, |h| or |Ŝ × k̂|) raises
    ``ZeroDivisionError``, numba's error model: the caller takes it as degenerate too."""
    for i in range(6):
        if not np.isfinite(x[i]):
            return BPLANE_DEGENERATE
    k0, k1, k2 = pole[0], pole[1], pole[2]
    rr = _dot(x[0], x[1], x[2], x[0], x[1], x[2])
    if not rr > 0.0 or not _dot(x[3], x[4], x[5], x[3], x[4], x[5]) / 2.0 - mu / np.sqrt(rr) > 0.0:
        return BPLANE_DEGENERATE
    bdr, bdt, dtp, vinf, hmag, skmag, e = _values(x[0], x[1], x[2], x[3], x[4], x[5], mu, k0, k1, k2)
    if not (hmag > 0.0 and skmag > 0.0 and e > 1.0):
        return BPLANE_DEGENERATE
    values[0], values[1], values[2], values[3] = bdr, bdt, dtp, vinf
    big = 1.0
    for i in range(6):
        big = max(big, abs(x[i]))
    step = 1e-30 * big
    xc = np.empty(6, dtype=np.complex128)
    for j in range(6):
        for i in range(6):
            xc[i] = x[i]
        xc[j] += 1j * step
        cr, ct, cp, _, _, _, _ = _values(xc[0], xc[1], xc[2], xc[3], xc[4], xc[5], mu, k0, k1, k2)
        jac[0, j] = cr.imag / step
        jac[1, j] = ct.imag / step
        jac[2, j] = cp.imag / step
    for i in range(4):
        if not np.isfinite(values[i]):
            return BPLANE_DEGENERATE
    for i in range(3):
        for j in range(6):
            if not np.isfinite(jac[i, j]):
                return BPLANE_DEGENERATE
    return BPLANE_OK

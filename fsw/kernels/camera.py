"""Compiled kernel: the pinhole camera's light-time corrected image of a target and its partials.

The model of :mod:`fsw.models.optical` (its docstring derives it): with g = r_T − r and
w = v_T + V_M the target's SSB velocity, the line of sight d = g − w τ, τ = |d|/c (four
fixed-point passes, or d = g without light time), ∂d/∂r = −(I − w uᵀ/(c + u·w)), u = d/|d|;
with aberration d_app = u + (v + V_M)/c, ∂d_app/∂r = (I − u uᵀ)/|d| ∂d/∂r, ∂d_app/∂v = I/c. In
the camera frame [x y z]ᵀ = Cᵀ d:

    sample = c_s + f x/z,   line = c_l + f y/z,   ∂[sample, line]/∂(Cᵀd) = [[f/z, 0, −f x/z²], [0, f/z, −f y/z²]].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources
from fsw.kernels.codes import AT_TARGET, BEHIND_CAMERA, OK

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit("int64(float64[:, ::1], float64[:, ::1], float64[::1], float64[::1], float64[:, ::1], float64[::1], "
      "float64[:, ::1], boolean[::1], boolean[::1], float64, float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1])",
      cache=True)
def pinhole_image(g, v, w, v_mars, C, focal, principal, light_time, aberration, c_km_s, h, Hr, Hv):
    """[sample, line] h (N, 2) and its partials Hr, Hv (N, 2, 3) for g = r_T − r (N, 3), the
    spacecraft velocities v (N, 3), the target's SSB velocity w (3,), Mars' SSB velocity (3,),
    the attitude C (camera → ICRF, 3 × 3) and per-filter camera parameters. Returns
    AT_TARGET if a line of sight is zero, BEHIND_CAMERA if a target has z ≤ 0, else OK."""
    N = g.shape[0]
    d = np.empty(3)
    u = np.empty(3)
    ddr = np.empty((3, 3))
    tmp = np.empty((3, 3))
    JC = np.empty((2, 3))
    code = OK
    for i in range(N):
        for j in range(3):
            d[j] = g[i, j]
        if light_time[i]:
            for _ in range(4):
                tau = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / c_km_s
                for j in range(3):
                    d[j] = g[i, j] - w[j] * tau
        dist = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        if not dist > 0.0:
            code = AT_TARGET
            continue
        uw = 0.0
        for j in range(3):
            u[j] = d[j] / dist
            uw += u[j] * w[j]
        lt = 1.0 if light_time[i] else 0.0
        for a in range(3):
            for b in range(3):
                ddr[a, b] = -((1.0 if a == b else 0.0) - lt * (w[a] * u[b]) / (c_km_s + uw))
        dv_scale = 0.0
        if aberration[i]:
            for a in range(3):
                for b in range(3):
                    acc = 0.0
                    for k in range(3):
                        acc += ((1.0 if a == k else 0.0) - u[a] * u[k]) / dist * ddr[k, b]
                    tmp[a, b] = acc
            for a in range(3):
                for b in range(3):
                    ddr[a, b] = tmp[a, b]
                d[a] = u[a] + (v[i, a] + v_mars[a]) / c_km_s
            dv_scale = 1.0 / c_km_s
        cx = d[0] * C[0, 0] + d[1] * C[1, 0] + d[2] * C[2, 0]
        cy = d[0] * C[0, 1] + d[1] * C[1, 1] + d[2] * C[2, 1]
        cz = d[0] * C[0, 2] + d[1] * C[1, 2] + d[2] * C[2, 2]
        if not cz > 0.0:
            if code == OK:
                code = BEHIND_CAMERA
            continue
        f = focal[i] / cz
        h[i, 0] = principal[i, 0] + f * cx
        h[i, 1] = principal[i, 1] + f * cy
        for k in range(3):
            JC[0, k] = f * C[k, 0] + (-f * cx / cz) * C[k, 2]
            JC[1, k] = f * C[k, 1] + (-f * cy / cz) * C[k, 2]
        for a in range(2):
            for b in range(3):
                Hr[i, a, b] = JC[a, 0] * ddr[0, b] + JC[a, 1] * ddr[1, b] + JC[a, 2] * ddr[2, b]
                Hv[i, a, b] = JC[a, b] * dv_scale
    return code

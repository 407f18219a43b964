"""Compiled kernel: one optical image (a target's [sample, line]) through the EKF bank — the leg,
the pinhole prediction and the Joseph update in one call.

The composition of the per-equation kernels, in the order the bank runs them one by one, so its
results are theirs to the bit:

1. (unless the bank is at the image epoch t1 already) the leg from t0 to t1
   (:func:`fsw.kernels.leg.fly_leg`);
2. the line of sight g = r_T − r and the velocity v of every filter's state at t1, then the
   light-time corrected pinhole image and its partials (:func:`fsw.kernels.camera.pinhole_image`),
   laid into H (N, 2, n) over the position and velocity columns;
3. R = diag((s σ_sample)², (s σ_line)²) per filter and the Joseph update
   (:func:`fsw.kernels.joseph_update.joseph_update`; the chi-square of Lubey & Ely 2022 eq. 6).

A geometry the camera cannot image (a line of sight of zero, a target behind the camera) stops
the step after the leg with the camera's code; the caller then leaves the image to the bank's
step-by-step path, which rejects it as it rejects any image it cannot predict.
"""

from __future__ import annotations

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()

from fsw.kernels.camera import pinhole_image  # noqa: E402  (after the cache set-up)
from fsw.kernels.codes import OK  # noqa: E402
from fsw.kernels.joseph_update import joseph_update  # noqa: E402
from fsw.kernels.leg import drivers_into, fly_leg  # noqa: E402
# the signature fragments every step shares
from fsw.kernels.leg import F as _F, M as _M, T as _T, V as _V  # noqa: E402
from fsw.kernels.leg import DRIVERS as _DRIVERS, LEG as _LEG, TRANSITION as _TRANSITION, UPDATE as _UPDATE  # noqa: E402

# r_T, w, v_mars, C, focal, principal, light_time, aberration, c_km_s
_CAMERA = f"{_V}, {_V}, {_V}, {_M}, {_V}, {_M}, boolean[::1], boolean[::1], {_F}"
_OPTICAL_STEP = (
    f"int64(boolean, {_LEG}, {_TRANSITION}, {_CAMERA}, "
    f"{_M}, {_M}, {_M}, {_T}, {_T}, {_T}, {_V}, {_V}, {_T}, {_UPDATE}, {_DRIVERS})"  # g, v, h, Hr, Hv, H, scale, sigma, R
)


@njit(_OPTICAL_STEP, cache=True)
def optical_step(fly, t0, t1, x, P, q, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step,
                 frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm,
                 src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop,
                 r_T, w, v_mars, C, focal, principal, light_time, aberration, c_km_s,
                 g, v, h, Hr, Hv, H, scale, sigma, R,
                 y, does, gate, residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out):
    """One image at t1 after a leg from t0 (see the module docstring): OK when done, else the
    camera's code (the leg is flown; nothing else is written).

    In: with ``fly``, the arguments of ``fly_leg``; without, the bank is at t1 already: x_prop
    and P_prop are its state (the leg's other arguments are not read). The target's Mars-centred
    position r_T (3,) at t1, its SSB velocity w (3,), Mars' SSB velocity, the attitude C (camera
    → ICRF) and the per-filter camera parameters (those of ``pinhole_image``); the per-filter
    sigma scales (N,), the reported sigmas (2,); the measurement y (2,), which filters update
    (``does``) and their chi-square gates.
    Out: the leg (z1, Y, x_prop, P_prop at t1), g and v (N, 3), h (N, 2), Hr and Hv (N, 2, 3),
    H (N, 2, n), R (N, 2, 2), the update (the arguments of ``joseph_update`` after ``gate``) and
    the drivers of the updated states (``drivers_into``)."""
    if fly:
        fly_leg(t0, t1, x, P, q, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step,
                frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm, src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop)
    N = x_prop.shape[0]
    for i in range(N):
        for j in range(3):
            g[i, j] = r_T[j] - x_prop[i, j]
            v[i, j] = x_prop[i, 3 + j]
    code = pinhole_image(g, v, w, v_mars, C, focal, principal, light_time, aberration, c_km_s, h, Hr, Hv)
    if code != OK:
        return code
    H[:, :, :] = 0.0
    for i in range(N):
        for a in range(2):
            for b in range(3):
                H[i, a, b] = Hr[i, a, b]
                H[i, a, 3 + b] = Hv[i, a, b]
            var = scale[i] * sigma[a]
            var = var * var
            for b in range(2):
                R[i, a, b] = var * (1.0 if a == b else 0.0)
    joseph_update(x_prop, P_prop, H, R, y, h, does, gate, residual, x_out, P_out, S, chi2, processed)
    drivers_into(x_out, q_first, q_second, q_out)
    return OK

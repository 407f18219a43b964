"""Compiled kernel: one one-way Doppler count through the EKF bank — time update, prediction and
Joseph update in one call.

The count ends at the time tag t1 and began T earlier: at the bank's last epoch t0 (one Doppler
count per count interval, the usual tracking pass), or before it (a range measurement came in
between); or the bank is at t1 already (a range measurement with the same time tag came first)
and the count spans the leg that brought it there. The step is the composition of the per-equation kernels, in the order the bank runs
them one by one, so its results are theirs to the bit:

1. (unless the bank is at t1) the trajectory and its sensitivity Y over [t0, t1] (:func:`fsw.kernels.variational_rk4.rk4_variational`)
   and the time update x̄ = Φ(x), P̄ = Φ P Φᵀ + Q (:func:`fsw.kernels.time_update.time_update`);
2. the count's start state from that leg's STM (:func:`fsw.kernels.count_start.count_start_from_leg`),
   or, if the count began before t0, propagated back from t1 by T;
3. the uplink light time at both ends of the count (Lubey & Ely 2022 §4.1,
   :func:`fsw.kernels.light_time.uplink_solution`) and the Doppler prediction and partials
   h = Δρ_g/T + c (f − a T/2) (:func:`fsw.kernels.doppler.doppler_prediction`);
4. R = (s σ)² + the clock's variance over the count, per filter, and the Joseph update
   (:func:`fsw.kernels.joseph_update.joseph_update`; the chi-square of Lubey & Ely 2022 eq. 6).

If the transmit epochs need another ephemeris table or station node than the caller handed in,
:func:`doppler_step` stops after the reception epochs and returns 1 (the time update is done: its
results are in ``z1, Y, x_prop, P_prop``); the caller looks the table and node up and
:func:`doppler_finish` completes the count.
"""

from __future__ import annotations

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()

from fsw.kernels.count_start import count_start_from_leg  # noqa: E402  (after the cache set-up)
from fsw.kernels.doppler import doppler_prediction  # noqa: E402
from fsw.kernels.joseph_update import joseph_update  # noqa: E402
from fsw.kernels.light_time import uplink_light_time, uplink_solution  # noqa: E402
from fsw.kernels.time_update import time_update  # noqa: E402
from fsw.kernels.variational_rk4 import rk4_variational  # noqa: E402

_F = "float64"
_V = "float64[::1]"
_M = "float64[:, ::1]"
_T = "float64[:, :, ::1]"
_TABLE = f"{_T}, {_T}, {_F}, {_F}"  # tab_p, tab_v, tab_t0, tab_step
_LIGHT_TIME = f"{_F}, {_F}, {_F}, {_F}, int64"  # t_grid, omega, gm_sun, c_km_s, iterations
_PREDICTION = f"{_M}, {_T}, {_V}, {_F}, {_V}, {_T}"  # h, H, scale, sigma, added, R
_UPDATE = f"{_V}, boolean[::1], {_V}, {_M}, {_M}, {_T}, {_T}, {_V}, boolean[::1]"  # y ... processed
_STEP = (
    "int64("
    # the leg: epochs, states, drivers, force model, ephemeris tables (the leg's, the count's), transition, noise
    f"boolean, {_F}, {_F}, {_M}, {_T}, {_M}, {_M}, "
    f"{_V}, {_V}, {_T}, int64, {_V}, {_F}, {_F}, {_F}, {_F}, {_TABLE}, {_V}, boolean, {_TABLE}, "
    f"int64[::1], int64, int64, {_M}, {_V}, "
    f"{_M}, {_T}, {_M}, {_T}, "
    # the count: its length, both ends, the light time with its table and station node
    f"{_F}, {_T}, {_T}, {_V}, {_V}, "
    f"{_T}, {_F}, {_F}, {_F}, {_F}, {_M}, {_LIGHT_TIME}, "
    f"{_T}, {_M}, {_V}, {_M}, {_T}, {_T}, {_M}, "
    # prediction, noise, update
    f"{_PREDICTION}, {_UPDATE})"
)
_FINISH = (
    "void("
    f"{_V}, {_V}, {_T}, {_T}, {_M}, {_V}, {_T}, {_F}, {_F}, {_M}, {_LIGHT_TIME}, {_M}, {_T}, {_T}, {_M}, "
    f"{_T}, {_M}, {_T}, {_F}, int64[::1], int64, int64, {_PREDICTION}, {_UPDATE})"
)


@njit(cache=True)
def _predict_and_update(rho, ku, d_rho_d_delta, delta, Yb, src, x_prop, P_prop, count_s, c0, c1, c_km_s,
                        h, H, scale, sigma, added, R, y, does, gate, residual, x_out, P_out, S, chi2, processed):
    """Steps 3 (the prediction, from the light time) and 4 of the module docstring."""
    doppler_prediction(rho, ku, d_rho_d_delta, delta, Yb, src, x_prop, count_s, c0, c1, c_km_s, h, H)
    for i in range(x_prop.shape[0]):
        v = scale[i] * sigma
        v = v * v
        R[i, 0, 0] = v + added[i]
    joseph_update(x_prop, P_prop, H, R, y, h, does, gate, residual, x_out, P_out, S, chi2, processed)


@njit(_STEP, cache=True)
def doppler_step(fly, t0, t1, x, P, q, q_leg,
                 srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step, frozen_tol,
                 tab_p, tab_v, tab_t0, tab_step, gm, from_leg, back_p, back_v, back_t0, back_step,
                 src, c0, c1, clock_q, snc,
                 z1, Y, x_prop, P_prop,
                 count_s, z, Yb, tt, delta,
                 herm, t_first, step, lo_ok, hi_ok, node, t_grid, omega, gm_sun, c_km_s, iterations,
                 r_sc, v_mars, t_g, rho, ku, d_rho_d_v, d_rho_d_delta,
                 h, H, scale, sigma, added, R,
                 y, does, gate, residual, x_out, P_out, S, chi2, processed):
    """One Doppler count (see the module docstring): 0 when done, 1 when the transmit epochs need
    another table or station node (the time update, the count's start and the reception are done).

    In, with ``fly``: the bank at t0 — x (N, n), P (N, n, n), drivers q (N, n_q) (``q_leg`` is q);
    the propagator's force parameters and the ephemeris table of the leg (the arguments of
    ``rk4_variational`` after ``with_stm``); ``from_leg``: the count begins at t0 (its start from
    the leg's STM), else it began earlier and its start is propagated back from t1 with the
    table ``back_*``. Without ``fly`` the bank is at t1 already and the count spans the last leg:
    x, q_leg, z1 and Y are that leg's start state, drivers, end and sensitivity, x_prop and P_prop
    the bank's state and q its drivers (P and the tables are not read; ``from_leg`` is true). The
    transition's column sources, clock block [c0, c1), clock noise (N, 3) and SNC (N,). The count:
    T = ``count_s``; the Hermite table and station node for its transmit epochs with the span
    they serve (the arguments of ``uplink_solution``); per-filter sigma scales (N,), the reported
    sigma, the clock's added variance (N,); the measurement y (1,), which filters update
    (``does``) and their chi-square gates.
    Out: the leg (z1 (N, 6), Y, x_prop, P_prop at t1), the count's ends z (2, N, 6), Yb, tt,
    δ (N,), the light-time arrays, h (N, 1), H (N, 1, n), R (N, 1, 1), and the update (the
    arguments of ``joseph_update`` after ``gate``)."""
    N = x.shape[0]
    if fly:
        for i in range(N):
            for j in range(6):
                z1[i, j] = x[i, j]
        rk4_variational(t0, t1, z1, q, True, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa,
                        max_step, frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm, Y)
        time_update(x, z1, P, Y, src, c0, c1, t1 - t0, clock_q, snc, x_prop, P_prop)
    for i in range(N):
        delta[i] = x_prop[i, c0] if c1 > c0 else 0.0
        for j in range(6):
            z[0, i, j] = x_prop[i, j]
    if from_leg:
        count_start_from_leg(Y, x, z1, x_prop, q, q_leg, z[1], Yb)
    else:
        for i in range(N):
            for j in range(6):
                z[1, i, j] = x_prop[i, j]
        rk4_variational(t1, t1 - count_s, z[1], q, True, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin,
                        kappa, max_step, frozen_tol, back_p, back_v, back_t0, back_step, gm, Yb)
    tt[0] = t1
    tt[1] = t1 - count_s
    if uplink_solution(tt, z, delta, herm, t_first, step, lo_ok, hi_ok, node, t_grid, omega, gm_sun, c_km_s,
                       iterations, r_sc, v_mars, t_g, rho, ku, d_rho_d_v, d_rho_d_delta) != 0:
        return 1
    _predict_and_update(rho, ku, d_rho_d_delta, delta, Yb, src, x_prop, P_prop, count_s, c0, c1, c_km_s,
                        h, H, scale, sigma, added, R, y, does, gate, residual, x_out, P_out, S, chi2, processed)
    return 0


@njit(_FINISH, cache=True)
def doppler_finish(tt, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun, c_km_s,
                   iterations, rho, ku, d_rho_d_v, d_rho_d_delta,
                   Yb, x_prop, P_prop, count_s, src, c0, c1, h, H, scale, sigma, added, R,
                   y, does, gate, residual, x_out, P_out, S, chi2, processed):
    """The rest of a count :func:`doppler_step` left at 1, with the table and station node of its
    transmit epochs t_g: the light time from the reception it solved
    (:func:`fsw.kernels.light_time.uplink_light_time`), then steps 3 and 4."""
    uplink_light_time(tt, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun, c_km_s,
                      iterations, rho, ku, d_rho_d_v, d_rho_d_delta)
    _predict_and_update(rho, ku, d_rho_d_delta, delta, Yb, src, x_prop, P_prop, count_s, c0, c1, c_km_s,
                        h, H, scale, sigma, added, R, y, does, gate, residual, x_out, P_out, S, chi2, processed)

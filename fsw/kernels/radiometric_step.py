"""Compiled kernels: one one-way radiometric measurement through the EKF bank — time update,
prediction and Joseph update in one call — for a Doppler count and for a range measurement.

Each step is the composition of the per-equation kernels, in the order the bank runs them one by
one, so its results are theirs to the bit:

1. (unless the bank is at the time tag t1 already) the leg to t1 (:func:`fsw.kernels.leg.fly_leg`:
   the trajectory, its sensitivity Y and the time update x̄ = Φ(x), P̄ = Φ P Φᵀ + Q);
2. for a Doppler count over T ending at t1: the count's start from the leg's STM
   (:func:`fsw.kernels.count_start.count_start_from_leg`) when the count spans the leg (one count
   per count interval, the usual tracking pass; or the bank is at t1 already, a range measurement
   with the same time tag having come first, and the count spans the leg that brought it there),
   else propagated back from t1 by T (a range measurement came between);
3. the uplink light time (Lubey & Ely 2022 §4.1, :func:`fsw.kernels.light_time.uplink_solution`) at
   the reception epoch(s) and the prediction with its partials: a Doppler count's
   h = Δρ_g/T + c (f − a T/2) (:func:`fsw.kernels.doppler.doppler_prediction`), a range's
   ρ = ρ_g + c δ (+ range bias) (:func:`fsw.kernels.one_way_range.range_prediction`);
4. R = (s σ)² per filter (plus, for a count, the clock's variance over it) and the Joseph update
   (:func:`fsw.kernels.joseph_update.joseph_update`; the chi-square of Lubey & Ely 2022 eq. 6).

If the transmit epochs need another ephemeris table or station node than the caller handed in,
a step stops after the reception epochs and returns 1 (the time update is done: its results are
in ``z1, Y, x_prop, P_prop``); the caller looks the table and node up and the step's ``finish``
kernel completes it.
"""

from __future__ import annotations

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()

from fsw.kernels.count_start import count_start_from_leg  # noqa: E402  (after the cache set-up)
from fsw.kernels.doppler import doppler_prediction  # noqa: E402
from fsw.kernels.joseph_update import joseph_update  # noqa: E402
from fsw.kernels.leg import fly_leg  # noqa: E402
# the signature fragments every step shares
from fsw.kernels.leg import F as _F, M as _M, T as _T, V as _V  # noqa: E402
from fsw.kernels.leg import DRIVERS as _DRIVERS, LEG as _LEG, TABLE as _TABLE, TRANSITION as _TRANSITION  # noqa: E402
from fsw.kernels.leg import UPDATE as _UPDATE, drivers_into  # noqa: E402
from fsw.kernels.light_time import uplink_light_time, uplink_solution  # noqa: E402
from fsw.kernels.one_way_range import range_prediction  # noqa: E402
from fsw.kernels.variational_rk4 import rk4_variational  # noqa: E402

_HERMITE = f"{_T}, {_F}, {_F}"  # herm, t_first, step
_LIGHT_TIME = f"{_F}, {_F}, {_F}, {_F}, int64"  # t_grid, omega, gm_sun, c_km_s, iterations
_SOLUTION = f"{_M}, {_T}, {_T}, {_M}"  # rho, ku, d_rho_d_v, d_rho_d_delta
_RECEPTION = f"{_T}, {_M}, {_V}"  # r_sc, v_mars, t_g
_DOPPLER_STEP = (
    f"int64(boolean, {_LEG}, {_M}, boolean, {_TABLE}, {_TRANSITION}, "
    f"{_F}, {_T}, {_T}, {_V}, {_V}, "  # count_s, z, Yb, tt, delta
    f"{_HERMITE}, {_F}, {_F}, {_M}, {_LIGHT_TIME}, {_RECEPTION}, {_SOLUTION}, "
    f"{_M}, {_T}, {_V}, {_F}, {_V}, {_T}, {_UPDATE}, {_DRIVERS})"  # h, H, scale, sigma, added, R
)
_DOPPLER_FINISH = (
    f"void({_V}, {_V}, {_T}, {_T}, {_M}, {_V}, {_HERMITE}, {_M}, {_LIGHT_TIME}, {_SOLUTION}, "
    f"{_T}, {_M}, {_T}, {_F}, int64[::1], int64, int64, {_M}, {_T}, {_V}, {_F}, {_V}, {_T}, {_UPDATE}, {_DRIVERS})"
)
_RANGE_STEP = (
    f"int64({_LEG}, {_TRANSITION}, {_T}, {_V}, {_V}, "  # z, tt, delta
    f"{_HERMITE}, {_F}, {_F}, {_M}, {_LIGHT_TIME}, {_RECEPTION}, {_SOLUTION}, "
    f"boolean, int64, {_M}, {_T}, {_V}, {_F}, {_T}, {_UPDATE}, {_DRIVERS})"  # has_clock, bias, h, H, scale, sigma, R
)
_RANGE_FINISH = (
    f"void({_V}, {_V}, {_T}, {_T}, {_M}, {_V}, {_HERMITE}, {_M}, {_LIGHT_TIME}, {_SOLUTION}, "
    f"{_M}, {_T}, boolean, int64, int64, {_M}, {_T}, {_V}, {_F}, {_T}, {_UPDATE}, {_DRIVERS})"
)


@njit(cache=True)
def _reception(x_prop, c0, c1, z, delta):
    """The clock phase δ at t1 and the states' [r, v] as the light time's first epoch."""
    for i in range(x_prop.shape[0]):
        delta[i] = x_prop[i, c0] if c1 > c0 else 0.0
        for j in range(6):
            z[0, i, j] = x_prop[i, j]


@njit(cache=True)
def _noise_and_update(scale, sigma, added, with_added, x_prop, P_prop, H, R, y, h, does, gate,
                      residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out):
    """Step 4 for a scalar measurement: R = (s σ)² (+ the added variance) per filter, then Joseph,
    then the drivers of the updated states."""
    for i in range(x_prop.shape[0]):
        v = scale[i] * sigma
        v = v * v
        R[i, 0, 0] = v + added[i] if with_added else v
    joseph_update(x_prop, P_prop, H, R, y, h, does, gate, residual, x_out, P_out, S, chi2, processed)
    drivers_into(x_out, q_first, q_second, q_out)


@njit(_DOPPLER_STEP, cache=True)
def doppler_step(fly, t0, t1, x, P, q, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step,
                 frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm, q_leg, from_leg, back_p, back_v, back_t0, back_step,
                 src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop,
                 count_s, z, Yb, tt, delta,
                 herm, t_first, step, lo_ok, hi_ok, node, t_grid, omega, gm_sun, c_km_s, iterations,
                 r_sc, v_mars, t_g, rho, ku, d_rho_d_v, d_rho_d_delta,
                 h, H, scale, sigma, added, R,
                 y, does, gate, residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out):
    """One Doppler count (see the module docstring): 0 when done, 1 when the transmit epochs need
    another table or station node (then :func:`doppler_finish`).

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
    arguments of ``joseph_update`` after ``gate``) and the drivers of the updated
    states (``drivers_into``)."""
    if fly:
        fly_leg(t0, t1, x, P, q, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step,
                frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm, src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop)
    _reception(x_prop, c0, c1, z, delta)
    if from_leg:
        count_start_from_leg(Y, x, z1, x_prop, q, q_leg, z[1], Yb)
    else:
        for i in range(x.shape[0]):
            for j in range(6):
                z[1, i, j] = x_prop[i, j]
        rk4_variational(t1, t1 - count_s, z[1], q, True, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin,
                        kappa, max_step, frozen_tol, back_p, back_v, back_t0, back_step, gm, Yb)
    tt[0] = t1
    tt[1] = t1 - count_s
    if uplink_solution(tt, z, delta, herm, t_first, step, lo_ok, hi_ok, node, t_grid, omega, gm_sun, c_km_s,
                       iterations, r_sc, v_mars, t_g, rho, ku, d_rho_d_v, d_rho_d_delta) != 0:
        return 1
    doppler_prediction(rho, ku, d_rho_d_delta, delta, Yb, src, x_prop, count_s, c0, c1, c_km_s, h, H)
    _noise_and_update(scale, sigma, added, True, x_prop, P_prop, H, R, y, h, does, gate,
                      residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out)
    return 0


@njit(_DOPPLER_FINISH, cache=True)
def doppler_finish(tt, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun, c_km_s,
                   iterations, rho, ku, d_rho_d_v, d_rho_d_delta,
                   Yb, x_prop, P_prop, count_s, src, c0, c1, h, H, scale, sigma, added, R,
                   y, does, gate, residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out):
    """The rest of a count :func:`doppler_step` left at 1, with the table and station node of its
    transmit epochs t_g: the light time from the reception it solved
    (:func:`fsw.kernels.light_time.uplink_light_time`), then steps 3 and 4."""
    uplink_light_time(tt, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun, c_km_s,
                      iterations, rho, ku, d_rho_d_v, d_rho_d_delta)
    doppler_prediction(rho, ku, d_rho_d_delta, delta, Yb, src, x_prop, count_s, c0, c1, c_km_s, h, H)
    _noise_and_update(scale, sigma, added, True, x_prop, P_prop, H, R, y, h, does, gate,
                      residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out)


@njit(_RANGE_STEP, cache=True)
def range_step(t0, t1, x, P, q, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step,
               frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm,
               src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop,
               z, tt, delta,
               herm, t_first, step, lo_ok, hi_ok, node, t_grid, omega, gm_sun, c_km_s, iterations,
               r_sc, v_mars, t_g, rho, ku, d_rho_d_v, d_rho_d_delta,
               has_clock, bias, h, H, scale, sigma, R,
               y, does, gate, residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out):
    """One range measurement at t1 after a leg from t0 (see the module docstring): 0 when done, 1
    when its transmit epoch needs another table or station node (then :func:`range_finish`).
    The arguments are :func:`doppler_step`'s for a flown leg; z (1, N, 6) and tt (1,) hold the one
    reception epoch; ``has_clock``: the states have a clock (phase in column c0); ``bias``: the
    range-bias column (−1: none)."""
    fly_leg(t0, t1, x, P, q, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step,
            frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm, src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop)
    _reception(x_prop, c0, c1, z, delta)
    tt[0] = t1
    if uplink_solution(tt, z, delta, herm, t_first, step, lo_ok, hi_ok, node, t_grid, omega, gm_sun, c_km_s,
                       iterations, r_sc, v_mars, t_g, rho, ku, d_rho_d_v, d_rho_d_delta) != 0:
        return 1
    range_prediction(rho, ku, d_rho_d_v, d_rho_d_delta, delta, x_prop, has_clock, c0, bias, c_km_s, h, H)
    _noise_and_update(scale, sigma, delta, False, x_prop, P_prop, H, R, y, h, does, gate,  # no added variance
                      residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out)
    return 0


@njit(_RANGE_FINISH, cache=True)
def range_finish(tt, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun, c_km_s,
                 iterations, rho, ku, d_rho_d_v, d_rho_d_delta,
                 x_prop, P_prop, has_clock, c0, bias, h, H, scale, sigma, R,
                 y, does, gate, residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out):
    """The rest of a range measurement :func:`range_step` left at 1 (as :func:`doppler_finish`)."""
    uplink_light_time(tt, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun, c_km_s,
                      iterations, rho, ku, d_rho_d_v, d_rho_d_delta)
    range_prediction(rho, ku, d_rho_d_v, d_rho_d_delta, delta, x_prop, has_clock, c0, bias, c_km_s, h, H)
    _noise_and_update(scale, sigma, delta, False, x_prop, P_prop, H, R, y, h, does, gate,  # no added variance
                      residual, x_out, P_out, S, chi2, processed, q_first, q_second, q_out)

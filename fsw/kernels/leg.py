"""Compiled kernel: the bank's leg from t0 to t1 — the trajectory and its sensitivity Y over
[t0, t1] (:func:`fsw.kernels.variational_rk4.rk4_variational`) and the time update x̄ = Φ(x),
P̄ = Φ P Φᵀ + Q (:func:`fsw.kernels.time_update.time_update`) — the first step of every whole-
measurement step (:mod:`fsw.kernels.radiometric_step`, :mod:`fsw.kernels.optical_step`)."""

from __future__ import annotations

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()

from fsw.kernels.time_update import time_update  # noqa: E402  (after the cache set-up)
from fsw.kernels.variational_rk4 import rk4_variational  # noqa: E402

# Fragments of the step kernels' signatures, for the arguments every step shares.
F = "float64"
V = "float64[::1]"
M = "float64[:, ::1]"
T = "float64[:, :, ::1]"
TABLE = f"{T}, {T}, {F}, {F}"  # tab_p, tab_v, tab_t0, tab_step
#: t0, t1, x, P, q, the force model (srp ... frozen_tol), the leg's table, gm
LEG = f"{F}, {F}, {M}, {T}, {M}, {V}, {V}, {T}, int64, {V}, {F}, {F}, {F}, {F}, {TABLE}, {V}"
#: src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop
TRANSITION = f"int64[::1], int64, int64, {M}, {V}, {M}, {T}, {M}, {T}"
#: y, does, gate and the outputs of the Joseph update (residual ... processed)
UPDATE = f"{V}, boolean[::1], {V}, {M}, {M}, {T}, {T}, {V}, boolean[::1]"
#: the driver columns (``EKFStack.driver_columns``) and the drivers of the updated state (out)
DRIVERS = f"int64[::1], int64[::1], {M}"


@njit(cache=True)
def drivers_into(x, first, second, q):
    """The acceleration drivers q (N, n_q) of the states x (N, n), as ``EKFStack.drivers`` picks
    them: q[:, j] = x[:, first[j]], plus x[:, second[j]] where second[j] ≥ 0 (nothing written for
    an empty ``first``). Written by the steps for the state they update, so the next leg does not
    pick them again."""
    for i in range(x.shape[0]):
        for j in range(first.shape[0]):
            v = x[i, first[j]]
            if second[j] >= 0:
                v += x[i, second[j]]
            q[i, j] = v


@njit(cache=True)
def fly_leg(t0, t1, x, P, q, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa, max_step, frozen_tol,
            tab_p, tab_v, tab_t0, tab_step, gm, src, c0, c1, clock_q, snc, z1, Y, x_prop, P_prop):
    """The leg's end z1, sensitivity Y and the time-updated x_prop, P_prop at t1, from the bank at t0
    (x, P, drivers q), the propagator's forces and the leg's ephemeris table (the arguments of
    ``rk4_variational`` after ``with_stm``), the transition's column sources, clock block [c0, c1),
    clock noise and SNC (those of ``time_update``)."""
    for i in range(x.shape[0]):
        for j in range(6):
            z1[i, j] = x[i, j]
    rk4_variational(t0, t1, z1, q, True, srp, acs_nominal, acs_body, deg, poly_batch, poly_origin, kappa,
                    max_step, frozen_tol, tab_p, tab_v, tab_t0, tab_step, gm, Y)
    time_update(x, z1, P, Y, src, c0, c1, t1 - t0, clock_q, snc, x_prop, P_prop)

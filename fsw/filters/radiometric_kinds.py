"""The onboard models of one-way range and Doppler: prediction and partials over a bank's
stacked states (geometry and light time: :mod:`fsw.models.radiometric`).

A Doppler count also carries the onboard clock's short-term instability over the count, which
the reported (thermal) sigma does not include and the clock states cannot represent
(:func:`doppler_clock_variance`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from fsw.astro.constants import C_KM_S, GM_SUN, OMEGA_EARTH_RAD_S
from fsw.astro.stations import StationError
from fsw.fdir.families import RADIO
from fsw.filters.errors import MeasurementRejected
from fsw.interface import kinds
from fsw.interface.messages import Measurement
from fsw.models.environment import Environment
from fsw.kernels import on_first_call
from fsw.models.radiometric import solve_uplinks, transmit_tables

doppler_prediction = on_first_call(globals(), "doppler_prediction", "fsw.kernels.doppler")
range_prediction = on_first_call(globals(), "range_prediction", "fsw.kernels.one_way_range")
doppler_step = on_first_call(globals(), "doppler_step", "fsw.kernels.radiometric_step")
doppler_finish = on_first_call(globals(), "doppler_finish", "fsw.kernels.radiometric_step")
range_step = on_first_call(globals(), "range_step", "fsw.kernels.radiometric_step")
range_finish = on_first_call(globals(), "range_finish", "fsw.kernels.radiometric_step")

if TYPE_CHECKING:
    from fsw.filters.ekf import EKFStack


def predict_range(stack: EKFStack, station: str, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """h (N, 1) and H (N, 1, n) of one-way range ρ = ρ_g + c δ (+ range bias) for states x (N, n)
    (geometry and light time: :func:`fsw.models.radiometric.solve_uplinks`; h and H:
    :func:`fsw.kernels.one_way_range.range_prediction`)."""
    clock = stack.clock_columns
    delta = np.ascontiguousarray(stack.clock_state(x, 0))
    w = stack.range_work
    w.z[0] = x[:, 0:6]
    w.tt[0] = t
    rho, ku, d_rho_d_v, d_rho_d_delta = solve_uplinks(stack.env, station, w.tt, w.z, delta, work=w.uplinks)
    N, n = x.shape
    h = np.empty((N, 1))
    H = np.empty((N, 1, n))
    range_prediction(rho, ku, d_rho_d_v, d_rho_d_delta, delta, x, clock is not None, clock[0] if clock else 0,
                     range_bias_column(stack), C_KM_S, h, H)
    return h, H


def range_bias_column(stack: EKFStack) -> int:
    """The range bias's column of the stack's states, −1 without one."""
    L = stack.layout
    return L.slices["range_bias"].start if L.has("range_bias") else -1


def predict_doppler(stack: EKFStack, station: str, t: float, count_s: float,
                    x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """h (N, 1) and H (N, 1, n) of one-way Doppler Δρ_g/T + c (f − a T/2) over the count
    interval T ending at t (the partials through the backward sensitivity of the count's start:
    :func:`fsw.kernels.doppler.doppler_prediction`)."""
    N, n = x.shape
    delta = np.ascontiguousarray(stack.clock_state(x, 0))
    w = stack.doppler_work
    # both ends of the count in one light-time solution: [end, start]
    z = w.z
    z[0] = x[:, 0:6]
    Yb = stack.count_start_into(t, count_s, x, z[1], w.Yb)
    tt = w.tt
    tt[0] = t
    tt[1] = t - count_s
    rho, ku, _, d_rho_d_delta = solve_uplinks(stack.env, station, tt, z, delta, work=w.uplinks)
    c0, c1 = stack.clock_columns or (0, 0)
    h = np.empty((N, 1))
    H = np.empty((N, 1, n))
    doppler_prediction(rho, ku, d_rho_d_delta, delta, Yb, stack.state_sources, x, count_s, c0, c1, C_KM_S, h, H)
    return h, H


def doppler_clock_variance(stack: EKFStack, count_s: float) -> np.ndarray:
    """(N,) variance [km²/s²] the clock adds to a one-way Doppler beyond its model c (f − a T/2).

    The count measures the phase change over T, (b_end − b_start)/T; white FM (q1) moves the
    phase by a random walk of variance q1 T inside the count and random-walk FM (q2) makes
    the mean frequency over the count differ from the modelled one by variance q2 T/3.
    Neither is in the frequency state, so each count carries c² (q1/T + q2 T/3) of its own
    (the Allan variance at τ = T of those two noises; 0.018 mm/s for a DSAC-class clock at
    60 s). Filters without clock states model no clock noise here."""
    return _clock_variance(stack, count_s)[1]


def _clock_variance(stack: EKFStack, count_s: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`doppler_clock_variance` kept for the next count of the same length: the array (for
    the compiled step, which only reads it) and a read-only view of it (handed out)."""
    q = stack.clock_q
    key = (count_s, q.tobytes())  # what the result depends on (q is tunable in flight)
    hit = _last_clock_variance[0]
    if hit is not None and hit[0] == key:
        return hit[1]
    out = (C_KM_S**2 / count_s) * q[:, 0] + (C_KM_S**2 * count_s / 3.0) * q[:, 1]
    view = out.view()
    view.flags.writeable = False
    _last_clock_variance[0] = (key, (out, view))
    return out, view


_last_clock_variance: list[tuple[tuple[float, bytes], tuple[np.ndarray, np.ndarray]] | None] = [None]


def _update_arrays(N: int, n: int) -> tuple[np.ndarray, ...]:
    """residual (N, 1), x⁺, P⁺, S (N, 1, 1), chi2, processed of a scalar measurement's update."""
    return (np.empty((N, 1)), np.empty((N, n)), np.empty((N, n, n)), np.empty((N, 1, 1)), np.empty(N),
            np.empty(N, dtype=bool))


def doppler_count_step(stack: EKFStack, station: str, t1: float, count_s: float, value: np.ndarray, sigma: float,
                       scale: np.ndarray, does: np.ndarray, gate: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """A Doppler count through the bank in compiled code (:mod:`fsw.kernels.radiometric_step`): the
    leg from the bank's epoch to the time tag t1, the prediction of :func:`predict_doppler`, R
    (reported ``sigma`` times each filter's ``scale``, squared, plus :func:`doppler_clock_variance`)
    and the Joseph update of the filters that ``does`` under their chi-square ``gate`` (inf: no
    editing). Returns (residual, S, chi2, processed) as :meth:`EKFStack.update` does.

    It applies when the leg to t1 is a plain one (:meth:`EKFStack.plain_leg`) — or the bank is at
    t1 already with nothing due there (:meth:`EKFStack.at_epoch`); otherwise it returns None with
    the bank untouched. The count's start comes from the leg just flown, or held (:meth:`EKFStack.held_leg`),
    when the count spans it, else it is propagated back (as :meth:`EKFStack.count_start` does);
    transmit epochs that need another table or node — or any node, when the last light-time
    solution was another station's (the first measurement of a pass) — are looked up between the
    two kernels, as :func:`~fsw.models.radiometric.solve_uplinks` looks them up."""
    env = stack.env
    node, t_grid = _station_node_or_none(env, station)
    t0 = stack.t
    start = t1 - count_s
    prop = stack.propagator
    w = stack.doppler_work
    N, n = stack.x.shape
    fly = t1 != t0
    if fly:
        flight = stack.plain_flight(t1)
        if flight is None:
            return None
        x, P, q, table, z1, Y, x_prop, P_prop = flight
        q_leg = q
        from_leg = abs(t0 - start) < 1e-6
        back = table if from_leg else prop.table(t1, start)
    else:
        held = stack.held_leg(t1, count_s)
        if held is not None:
            x, z1, q_leg, Y, q = held
            from_leg = True
            back = (w.z, w.z, 0.0, 1.0)  # nothing is flown back: not read
        elif stack.at_epoch(t1):
            # The count began before the leg that brought the bank to t1 (an estimate epoch or a
            # range measurement came in between): its start is propagated back from t1, as
            # EKFStack.count_start does; the leg's arrays are then not read.
            q = stack.state_drivers()
            x, z1, q_leg, Y = stack.x, w.z[0], q, w.Yb
            from_leg = False
            back = prop.table(t1, start)
        else:
            return None
        x_prop, P = stack.x, stack.P
        P_prop = P
        table = (w.z, w.z, 0.0, 1.0)  # nothing is flown: not read
    herm, t_first, step, lo_ok, hi_ok = env.hermite_window(min(t1, start) - 1.0, max(t1, start) + 1.0)
    c0, c1 = stack.clock_columns or (0, 0)
    u = w.uplinks
    first, second = stack.driver_columns
    update, q_new = _update_arrays(N, n), np.empty((N, first.size))
    added = _clock_variance(stack, count_s)[0]
    src = stack.state_sources
    status = doppler_step(fly, t0, t1, x, P, q, *prop.forces, *table, prop.GM, q_leg, from_leg, *back,
                          src, c0, c1, stack.clock_q, stack.snc_psd, z1, Y, x_prop, P_prop,
                          count_s, w.z, w.Yb, w.tt, w.delta,
                          herm, t_first, step, lo_ok, hi_ok, node, t_grid, OMEGA_EARTH_RAD_S, GM_SUN, C_KM_S, 2,
                          u.r_sc, u.v_mars, u.t_g, u.rho, u.ku, u.d_rho_d_v, u.d_rho_d_delta,
                          w.h, w.H, scale, sigma, added, w.R, value, does, gate, *update, first, second, q_new)
    if fly:
        stack.end_leg(t1, x, z1, q, Y, x_prop, P_prop)
    if status != 0:
        doppler_finish(w.tt, u.t_g, u.r_sc, w.z, u.v_mars, w.delta, *transmit_tables(env, station, u.t_g),
                       OMEGA_EARTH_RAD_S, GM_SUN, C_KM_S, 2, u.rho, u.ku, u.d_rho_d_v, u.d_rho_d_delta,
                       w.Yb, x_prop, P_prop, count_s, src, c0, c1, w.h, w.H, scale, sigma, added, w.R,
                       value, does, gate, *update, first, second, q_new)
    return _updated(stack, update, q_new)


def range_measurement_step(stack: EKFStack, station: str, t1: float, value: np.ndarray, sigma: float,
                           scale: np.ndarray, does: np.ndarray, gate: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """A range measurement through the bank in compiled code (:mod:`fsw.kernels.radiometric_step`):
    the leg from the bank's epoch to the time tag t1, the prediction of :func:`predict_range`, R
    (``sigma`` times each filter's ``scale``, squared) and the Joseph update, as
    :func:`doppler_count_step` for a count; None (the bank untouched) unless the leg is a plain one."""
    env = stack.env
    node, t_grid = _station_node_or_none(env, station)
    flight = stack.plain_flight(t1)
    if flight is None:
        return None
    x, P, q, table, z1, Y, x_prop, P_prop = flight
    t0 = stack.t
    prop = stack.propagator
    herm, t_first, step, lo_ok, hi_ok = env.hermite_window(t1 - 1.0, t1 + 1.0)
    clock = stack.clock_columns
    c0, c1 = clock or (0, 0)
    bias = range_bias_column(stack)
    w = stack.range_work
    u = w.uplinks
    N, n = x.shape
    first, second = stack.driver_columns
    update, q_new = _update_arrays(N, n), np.empty((N, first.size))
    status = range_step(t0, t1, x, P, q, *prop.forces, *table, prop.GM,
                        stack.state_sources, c0, c1, stack.clock_q, stack.snc_psd, z1, Y, x_prop, P_prop,
                        w.z, w.tt, w.delta,
                        herm, t_first, step, lo_ok, hi_ok, node, t_grid, OMEGA_EARTH_RAD_S, GM_SUN, C_KM_S, 2,
                        u.r_sc, u.v_mars, u.t_g, u.rho, u.ku, u.d_rho_d_v, u.d_rho_d_delta,
                        clock is not None, bias, w.h, w.H, scale, sigma, w.R, value, does, gate, *update, first, second,
                        q_new)
    stack.end_leg(t1, x, z1, q, Y, x_prop, P_prop)
    if status != 0:
        range_finish(w.tt, u.t_g, u.r_sc, w.z, u.v_mars, w.delta, *transmit_tables(env, station, u.t_g),
                     OMEGA_EARTH_RAD_S, GM_SUN, C_KM_S, 2, u.rho, u.ku, u.d_rho_d_v, u.d_rho_d_delta,
                     x_prop, P_prop, clock is not None, c0, bias, w.h, w.H, scale, sigma, w.R,
                     value, does, gate, *update, first, second, q_new)
    return _updated(stack, update, q_new)


#: No station node: a step handed it at the epoch −∞ stops after the reception epochs (no
#: transmit epoch lies within 300 s of it), never reading it, and its ``finish`` looks the node
#: up, as :func:`~fsw.models.radiometric.solve_uplinks` does when it has none. (Writable: the
#: kernels' signatures take writable arrays.)
_NO_NODE = np.zeros((4, 3))


def _station_node_or_none(env: Environment, station: str) -> tuple[np.ndarray, float]:
    """The station node the last light-time solution used, and its epoch, if it was this
    station's; else :data:`_NO_NODE` at −∞ (the first measurement of a station's pass)."""
    last = env.last_station_node(station)
    return (_NO_NODE, -math.inf) if last is None else last


def _updated(stack: EKFStack, update: tuple[np.ndarray, ...], q_new: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Take a compiled step's updated states (and their drivers) into the stack; (residual, S, chi2,
    processed)."""
    residual, x_new, P_new, S, chi2, processed = update
    stack.take_update(x_new, P_new, q_new)
    return residual, S, chi2, processed


def _check_station(meas: Measurement, env: Environment) -> None:
    try:
        env.check_station(meas.source)
    except StationError as exc:
        raise MeasurementRejected("unknown_source", str(exc)) from None


def count_time(meas: Measurement) -> float:
    """The Doppler count interval T [s]; refuses a missing, non-finite or non-positive one."""
    T = meas.count_time_s
    if type(T) is float and 0.0 < T < math.inf:
        return T
    # the message may not have been through the ICD's own checks: test the value, not its type hint
    if T is None or isinstance(T, bool) or not isinstance(T, (int, float)) or not math.isfinite(T) or T <= 0.0:
        raise MeasurementRejected("bad_count_time", f"Doppler needs a positive finite count_time_s, got {T!r}")
    return float(T)


class RangeModel:
    """One-way uplink pseudo-range."""

    declaration = kinds.RANGE
    family = RADIO

    def screen(self, meas: Measurement, env: Environment) -> None:
        _check_station(meas, env)

    def predict(self, stack: EKFStack, meas: Measurement, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return predict_range(stack, meas.source, t, x)

    def added_variance(self, stack: EKFStack, meas: Measurement) -> np.ndarray | None:
        return None

    def step(self, stack: EKFStack, meas: Measurement, t1: float, value: np.ndarray, sigma: np.ndarray,
             scale: np.ndarray, does: np.ndarray, gate: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        return range_measurement_step(stack, meas.source, t1, value, float(sigma[0]), scale, does, gate)


class DopplerModel:
    """One-way uplink Doppler over the count interval ending at the time tag."""

    declaration = kinds.DOPPLER
    family = RADIO

    def screen(self, meas: Measurement, env: Environment) -> None:
        _check_station(meas, env)
        count_time(meas)

    def predict(self, stack: EKFStack, meas: Measurement, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return predict_doppler(stack, meas.source, t, count_time(meas), x)

    def added_variance(self, stack: EKFStack, meas: Measurement) -> np.ndarray | None:
        return doppler_clock_variance(stack, count_time(meas))

    def step(self, stack: EKFStack, meas: Measurement, t1: float, value: np.ndarray, sigma: np.ndarray,
             scale: np.ndarray, does: np.ndarray, gate: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        return doppler_count_step(stack, meas.source, t1, count_time(meas), value, float(sigma[0]), scale, does, gate)

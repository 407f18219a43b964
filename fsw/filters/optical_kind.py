"""The onboard model of optical navigation images: prediction and partials over a bank's stacked
states (camera geometry: :mod:`fsw.models.optical`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from fsw.astro.constants import C_KM_S
from fsw.astro.frames import quat_to_matrix
from fsw.fdir.families import OPTICAL
from fsw.filters.errors import MeasurementRejected
from fsw.interface import kinds
from fsw.interface.messages import Measurement
from fsw.kernels import on_first_call
from fsw.kernels.codes import OK
from fsw.models.environment import MARS, OPTICAL_TARGETS, Environment
from fsw.models.optical import optical

optical_step = on_first_call(globals(), "optical_step", "fsw.kernels.optical_step")

if TYPE_CHECKING:
    from fsw.filters.ekf import EKFStack


def predict_optical(stack: EKFStack, target: str, t: float, attitude_q: ArrayLike,
                    x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """h (N, 2) and H (N, 2, n) of the [sample, line] of a target for states x (N, n)."""
    cams = stack.cameras
    h, Hr, Hv = optical(stack.env, target, t, x[:, 0:3], x[:, 3:6], np.asarray(attitude_q, dtype=float), *cams)
    H = np.zeros((x.shape[0], 2, stack.layout.n))
    H[:, :, 0:3] = Hr
    H[:, :, 3:6] = Hv
    return h, H


def optical_image_step(stack: EKFStack, target: str, t1: float, attitude_q: ArrayLike, value: np.ndarray,
                       sigma: np.ndarray, scale: np.ndarray, does: np.ndarray, gate: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """An image through the bank in compiled code (:mod:`fsw.kernels.optical_step`): the leg from
    the bank's epoch to the image epoch t1, the prediction of :func:`predict_optical`, R (each
    reported sigma times the filter's ``scale``, squared, on the diagonal) and the Joseph update
    of the filters that ``does`` under their chi-square ``gate`` (inf: no editing). Returns
    (residual, S, chi2, processed) as :meth:`EKFStack.update` does; None (the bank untouched)
    unless the leg is a plain one or the bank is at t1 already (:meth:`EKFStack.at_epoch`), and
    None after the leg when the camera cannot image the target (the bank's step-by-step path,
    then at t1, rejects the image as it rejects any)."""
    t0 = stack.t
    N, n = stack.x.shape
    work = stack.optical_work
    fly = t1 != t0
    if fly:
        flight = stack.plain_flight(t1)
        if flight is None:
            return None
        x, P, q, table, z1, Y, x_prop, P_prop = flight
    elif stack.at_epoch(t1):
        # nothing to fly (another measurement had this time tag): the leg's arguments are not read
        x_prop, P_prop = stack.x, stack.P
        x, P, q, z1, Y = x_prop, P_prop, work.g, work.g, work.Hr
        table = (work.Hr, work.Hr, 0.0, 1.0)
    else:
        return None
    env = stack.env
    # what optical() looks up for the image epoch, in its order, after the leg's table
    r_T, v_T = env.target_state(target, t1)
    Vm = env.states_ssb(t1)[1][MARS]
    focal, principal, light_time, aberration = stack.cameras
    c0, c1 = stack.clock_columns or (0, 0)
    prop = stack.propagator
    first, second = stack.driver_columns
    update = (np.empty((N, 2)), np.empty((N, n)), np.empty((N, n, n)), np.empty((N, 2, 2)), np.empty(N),
              np.empty(N, dtype=bool))
    q_new = np.empty((N, first.size))
    code = optical_step(fly, t0, t1, x, P, q, *prop.forces, *table, prop.GM,
                        stack.state_sources, c0, c1, stack.clock_q, stack.snc_psd, z1, Y, x_prop, P_prop,
                        np.ascontiguousarray(r_T, dtype=float), np.ascontiguousarray(v_T + Vm, dtype=float),
                        np.ascontiguousarray(Vm), quat_to_matrix(np.asarray(attitude_q, dtype=float)),
                        np.ascontiguousarray(focal, dtype=float), np.ascontiguousarray(principal, dtype=float),
                        np.ascontiguousarray(light_time, dtype=bool), np.ascontiguousarray(aberration, dtype=bool),
                        C_KM_S, work.g, work.v, work.h, work.Hr, work.Hv, work.H, scale, sigma, work.R,
                        value, does, gate, *update, first, second, q_new)
    if fly:
        stack.end_leg(t1, x, z1, q, Y, x_prop, P_prop)
    if code != OK:
        return None
    residual, x_new, P_new, S, chi2, processed = update
    stack.take_update(x_new, P_new, q_new)
    return residual, S, chi2, processed


def _attitude(meas: Measurement) -> tuple[float, ...]:
    q = meas.attitude_q
    if q is None:
        raise MeasurementRejected("missing_field", "an optical measurement needs attitude_q")
    return q


class OpticalModel:
    """[sample, line] of a target centre through the pinhole camera, at the attitude sent along."""

    declaration = kinds.OPTICAL
    family = OPTICAL

    def screen(self, meas: Measurement, env: Environment) -> None:
        source = meas.source
        if source not in OPTICAL_TARGETS:
            raise MeasurementRejected("unknown_source", f"unknown optical target {source!r}; known: {OPTICAL_TARGETS}")
        q = _attitude(meas)
        try:
            qa = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            raise MeasurementRejected("non_finite", f"attitude_q is not numeric: {q!r}") from None
        if qa.shape != (4,):
            raise MeasurementRejected("bad_dimension", f"attitude_q needs 4 components, got shape {qa.shape}")
        if not np.all(np.isfinite(qa)) or float(qa @ qa) < 1e-12:
            raise MeasurementRejected("non_finite", f"attitude_q must be a finite non-zero quaternion, got {qa.tolist()}")

    def predict(self, stack: EKFStack, meas: Measurement, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return predict_optical(stack, meas.source, t, _attitude(meas), x)

    def added_variance(self, stack: EKFStack, meas: Measurement) -> np.ndarray | None:
        return None

    def step(self, stack: EKFStack, meas: Measurement, t1: float, value: np.ndarray, sigma: np.ndarray,
             scale: np.ndarray, does: np.ndarray, gate: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        return optical_image_step(stack, meas.source, t1, _attitude(meas), value, sigma, scale, does, gate)

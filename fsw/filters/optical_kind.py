"""The onboard model of optical navigation images: prediction and partials over a bank's stacked
states (camera geometry: :mod:`fsw.models.optical`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from fsw.fdir.families import OPTICAL
from fsw.filters.errors import MeasurementRejected
from fsw.interface import kinds
from fsw.interface.messages import Measurement
from fsw.models.environment import OPTICAL_TARGETS, Environment
from fsw.models.optical import optical

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
             scale: np.ndarray, does: np.ndarray, gate: np.ndarray) -> None:
        return None

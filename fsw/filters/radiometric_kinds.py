"""The onboard models of one-way range and Doppler (:mod:`fsw.models.radiometric`).

A Doppler count also carries the onboard clock's short-term instability over the count, which
the reported (thermal) sigma does not include and the clock states cannot represent
(:meth:`fsw.filters.ekf.EKFStack.doppler_clock_variance`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from fsw.astro.stations import StationError
from fsw.fdir.families import RADIO
from fsw.filters.errors import MeasurementRejected
from fsw.interface import kinds
from fsw.interface.messages import Measurement
from fsw.models.environment import Environment

if TYPE_CHECKING:
    from fsw.filters.ekf import EKFStack


def _check_station(meas: Measurement, env: Environment) -> None:
    try:
        env.check_station(meas.source)
    except StationError as exc:
        raise MeasurementRejected("unknown_source", str(exc)) from None


def count_time(meas: Measurement) -> float:
    """The Doppler count interval T [s]; refuses a missing, non-finite or non-positive one."""
    T = meas.count_time_s
    # the message may not have been through the ICD's own checks: test the value, not its type hint
    if T is None or isinstance(T, bool) or not isinstance(T, (int, float)) or not math.isfinite(T) or T <= 0.0:
        raise MeasurementRejected("bad_count_time", f"Doppler needs a positive finite count_time_s, got {T!r}")
    return float(T)


class RangeModel:
    """One-way uplink pseudo-range ρ = ρ_g + c δ (+ range bias)."""

    declaration = kinds.RANGE
    family = RADIO

    def screen(self, meas: Measurement, env: Environment) -> None:
        _check_station(meas, env)

    def predict(self, stack: EKFStack, meas: Measurement, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return stack.predict_range(meas.source, t, x)

    def added_variance(self, stack: EKFStack, meas: Measurement) -> np.ndarray | None:
        return None


class DopplerModel:
    """One-way uplink Doppler over the count interval ending at the time tag."""

    declaration = kinds.DOPPLER
    family = RADIO

    def screen(self, meas: Measurement, env: Environment) -> None:
        _check_station(meas, env)
        count_time(meas)

    def predict(self, stack: EKFStack, meas: Measurement, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return stack.predict_doppler(meas.source, t, count_time(meas), x)

    def added_variance(self, stack: EKFStack, meas: Measurement) -> np.ndarray | None:
        return stack.doppler_clock_variance(count_time(meas))

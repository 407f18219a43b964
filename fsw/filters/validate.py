"""Screening of incoming measurements before they reach any filter.

A bank calls :func:`screen` first; it raises :class:`MeasurementRejected` with a reason, so a bad
message is refused (and counted by the bank) without touching any filter state.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from fsw.filters.errors import MeasurementRejected
from fsw.interface.messages import Measurement


def _finite_vector(values: object, name: str) -> np.ndarray:
    if type(values) is tuple and values and all([type(v) is float for v in values]):
        # what a decoded ICD message holds: tested as Python floats (a numpy reduction per
        # vector cost more than the rest of the screening)
        if not all(map(math.isfinite, values)):
            raise MeasurementRejected("non_finite", f"{name} has non-finite entries: {list(values)}")
        return np.array(values)
    try:
        arr = np.array(values, dtype=float)
    except (TypeError, ValueError):
        raise MeasurementRejected("non_finite", f"{name} is not numeric: {values!r}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise MeasurementRejected("bad_dimension", f"{name} must be a non-empty vector, got shape {arr.shape}")
    if not math.isfinite(float(arr.sum())):  # NaN and ±inf all propagate into the sum
        raise MeasurementRejected("non_finite", f"{name} has non-finite entries: {arr.tolist()}")
    return arr


def screen(meas: Measurement, dimensions: Mapping[str, int | None]) -> tuple[np.ndarray, np.ndarray]:
    """Check one ICD ``Measurement`` and return (value, sigma). The message may not have been
    through the ICD's own checks (hence every field is tested as found, not as declared).

    ``dimensions`` maps each kind this bank has a model for to its expected length (None: any).
    """
    kind = getattr(meas, "kind", None)
    if not isinstance(kind, str) or kind not in dimensions:
        raise MeasurementRejected("unknown_kind", f"no model for measurement kind {kind!r}")
    t = getattr(meas, "t_s", None)
    value = getattr(meas, "value", None)
    sigma = getattr(meas, "sigma", None)
    if type(t) is float and type(value) is tuple and type(sigma) is tuple and len(value) == 1 == len(sigma):
        # a scalar measurement as decoded (range, Doppler: most of them), tested on its three
        # Python floats at once; accepts only what the checks below accept (x - x is 0 exactly
        # for a finite x), anything else goes through them for its reason
        v, s = value[0], sigma[0]
        if (type(v) is float and type(s) is float and t - t == 0.0 and v - v == 0.0 and 0.0 < s < math.inf
                and dimensions.get(kind) in (None, 1)):
            return np.array(value), np.array(sigma)
    if isinstance(t, bool) or not isinstance(t, (int, float, np.floating)) or not math.isfinite(t):
        raise MeasurementRejected("non_finite", f"time tag {t!r} is not a finite number")
    value = _finite_vector(value, "value")
    sigma = _finite_vector(sigma, "sigma")
    want = dimensions.get(kind)
    if want is not None and value.size != want:
        raise MeasurementRejected("bad_dimension", f"{kind} has {want} component(s), got {value.size}")
    if sigma.size != value.size:
        raise MeasurementRejected("bad_dimension", f"sigma has {sigma.size} components, value {value.size}")
    if min(sigma.tolist()) <= 0.0:
        raise MeasurementRejected("bad_sigma", f"sigma must be > 0, got {sigma.tolist()}")
    return value, sigma

"""Screening of incoming measurements: every field tested as found, every refusal with its reason.

``screen`` takes a scalar measurement of three Python floats through a shortcut; it must accept
and refuse exactly what the field-by-field checks, written out here as they stood before it, do.
"""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace

import numpy as np
import pytest

from fsw.filters.errors import MeasurementRejected
from fsw.filters.validate import _finite_vector, screen

DIMENSIONS = {"range": 1, "doppler": 1, "optical": 2, "generic-linear": None}


def screen_field_by_field(meas, dimensions):
    """The checks in order, each field tested as found (the screening without its shortcut)."""
    kind = getattr(meas, "kind", None)
    if not isinstance(kind, str) or kind not in dimensions:
        raise MeasurementRejected("unknown_kind", "")
    t = getattr(meas, "t_s", None)
    if isinstance(t, bool) or not isinstance(t, (int, float, np.floating)) or not math.isfinite(t):
        raise MeasurementRejected("non_finite", "")
    value = _finite_vector(getattr(meas, "value", None), "value")
    sigma = _finite_vector(getattr(meas, "sigma", None), "sigma")
    want = dimensions.get(kind)
    if want is not None and value.size != want:
        raise MeasurementRejected("bad_dimension", "")
    if sigma.size != value.size:
        raise MeasurementRejected("bad_dimension", "")
    if min(sigma.tolist()) <= 0.0:
        raise MeasurementRejected("bad_sigma", "")
    return value, sigma


def _outcome(fn, meas):
    try:
        value, sigma = fn(meas, DIMENSIONS)
    except MeasurementRejected as exc:
        return exc.reason
    return (value.dtype, value.shape, value.tobytes(), sigma.dtype, sigma.shape, sigma.tobytes())


NAN, INF = math.nan, math.inf
TIMES = [6e8, NAN, INF, -INF, 600000000, True, np.float64(6e8), None, "6e8"]
VALUES = [(1.5e8,), (-0.0,), (NAN,), (INF,), (-INF,), (1,), (np.float64(2.0),), (), (1.0, 2.0), [1.0], None, ("x",),
          (True,)]
SIGMAS = [(1e-3,), (0.0,), (-1e-3,), (NAN,), (INF,), (5e-324,), (1,), (np.float64(1e-3),), (1e-3, 1e-3), ()]


@pytest.mark.parametrize("kind", ["range", "doppler", "optical", "generic-linear", "unknown", None])
def test_screening_accepts_and_refuses_what_the_field_by_field_checks_do(kind):
    for t, value, sigma in itertools.product(TIMES, VALUES, SIGMAS):
        meas = SimpleNamespace(kind=kind, t_s=t, value=value, sigma=sigma)
        assert _outcome(screen, meas) == _outcome(screen_field_by_field, meas), (kind, t, value, sigma)


def test_a_scalar_measurement_is_accepted_as_float_arrays_and_bad_ones_by_reason():
    value, sigma = screen(SimpleNamespace(kind="doppler", t_s=6e8, value=(13.7,), sigma=(1e-7,)), DIMENSIONS)
    assert value.dtype == sigma.dtype == np.float64 and value.tolist() == [13.7] and sigma.tolist() == [1e-7]
    for fields, reason in [(dict(t_s=NAN), "non_finite"), (dict(value=(INF,)), "non_finite"),
                           (dict(sigma=(NAN,)), "non_finite"), (dict(sigma=(0.0,)), "bad_sigma"),
                           (dict(kind="optical"), "bad_dimension"), (dict(kind="other"), "unknown_kind")]:
        meas = SimpleNamespace(**{**dict(kind="range", t_s=6e8, value=(1.5e8,), sigma=(1e-3,)), **fields})
        with pytest.raises(MeasurementRejected) as exc:
            screen(meas, DIMENSIONS)
        assert exc.value.reason == reason

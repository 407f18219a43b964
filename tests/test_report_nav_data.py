"""Residual traces: the arrays built from a recording's samples are numpy's own, also for malformed ones."""

import numpy as np
import pytest

from ground.report.nav_data import _stacked


def _numpy(rows, dtype):
    try:
        return np.array(rows, dtype=dtype), None
    except (TypeError, ValueError) as exc:
        return None, type(exc)


@pytest.mark.parametrize("rows", [
    [((1.0,), (2.0,), (-0.0,))] * 5,                     # range/Doppler: one component, three filters
    [((1.0, 2.0), (3.0, np.nan))] * 3,                   # optical: two components
    [(1.0, 2.0, 3.0)] * 4, [(True, False)] * 3, [(1, 2), (3, 4)], [[[1.0], [2.0]], [[3.0], [4.0]]],
    [], [()], [(), ()],
    [((1.0,), (2.0,)), ((1.0,), (2.0, 3.0))],             # a component of another length
    [((1.0,), (2.0,)), ((1.0,),)],                        # a row with a filter missing
    [((1.0, 2.0), (3.0,)), ((1.0,), (2.0, 3.0))],         # lengths that add up but do not match
    [(1.0, 2.0), (1.0,)], [(1.0, (2.0,))], [((1.0,), 2.0)], [("a", "b")],
])
@pytest.mark.parametrize("dtype", [float, bool])
def test_stacked_rows_are_numpys_array(rows, dtype):
    want, error = _numpy(rows, dtype)
    if error is not None:
        with pytest.raises(error):
            _stacked(rows, dtype)
        return
    got = _stacked(rows, dtype)
    assert got.shape == want.shape and got.dtype == want.dtype
    assert np.array_equal(got, want, equal_nan=dtype is float)
    assert np.array_equal(np.signbit(got), np.signbit(want))

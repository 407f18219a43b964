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


def test_residual_traces_group_sort_and_build_numpys_arrays():
    from fsw.interface import messages as m
    from ground.report.nav_data import nis_statistics, residual_traces

    def sample(t, seq, kind, source, n):
        z = tuple(tuple(float(seq + f + c) for c in range(n)) for f in range(2))
        return m.ResidualSample(t_s=t, seq=seq, kind=kind, source=source, residual=z, sigma=z, normalised=z,
                                nis=(float(seq), 2.0), processed=(True, seq % 2 == 0))
    samples = [sample(30.0 - k, k, "doppler", "DSS-14", 1) for k in range(6)] + [sample(5.0, 9, "optical", "phobos", 2)]
    msg = m.Residuals(t_s=40.0, timestamp=m.Stamp(sec=1, nsec=0), filters=("a", "b"), samples=tuple(samples))
    traces = residual_traces([msg])
    assert sorted(traces) == [("doppler", "DSS-14"), ("optical", "phobos")]
    dop = traces[("doppler", "DSS-14")]
    ordered = sorted(samples[:6], key=lambda s: s.t_s)
    assert dop.dimension == 1 and traces[("optical", "phobos")].dimension == 2
    assert np.array_equal(dop.t_s, [s.t_s for s in ordered])
    assert np.array_equal(dop.residual, np.array([s.residual for s in ordered])) and dop.residual.shape == (6, 2, 1)
    assert np.array_equal(dop.processed, np.array([s.processed for s in ordered]))
    assert dop.dimension == 1  # also once the residual array exists
    stats = nis_statistics(traces)
    assert stats["doppler"]["a"]["count"] == 6.0 and stats["doppler"]["b"]["count"] == 3.0
    assert stats["optical"]["a"]["dimension"] == 2.0

"""Weight histories in .npz: written with the arrays campaigns have always stored, and read back
from files that predate the statistics and bank columns."""

from __future__ import annotations

import numpy as np

from ground.report.run_weights import RunWeights


def test_round_trip_keeps_every_array(tmp_path):
    h = RunWeights(filters=("radio", "optical"), t_s=np.array([1.0, 2.0]), batch=np.array([0, 1]),
                   weights=np.array([[0.5, 0.5], [0.9, 0.1]]), statistic=np.array([[0.1, 0.2], [0.3, 0.4]]),
                   group_names=("radiometric",), groups=np.array([[0.6], [0.7]]))
    h.save(tmp_path / "h.npz")
    with np.load(tmp_path / "h.npz") as data:
        assert data.files == ["filters", "t_s", "batch", "weights", "groups", "group_names", "statistic"]
    got = RunWeights.load(tmp_path / "h.npz")
    assert got.filters == h.filters and got.group_names == h.group_names
    for name in ("t_s", "batch", "weights", "statistic", "groups"):
        np.testing.assert_array_equal(getattr(got, name), getattr(h, name))


def test_an_older_file_without_statistics_or_banks(tmp_path):
    np.savez(tmp_path / "old.npz", filters=np.array(["radio"]), t_s=np.array([1.0]), batch=np.array([0]),
             weights=np.array([[1.0]]))
    got = RunWeights.load(tmp_path / "old.npz")
    assert got.filters == ("radio",) and got.statistic.shape == (0, 0) and got.group_names == ()


def test_empty_history():
    e = RunWeights.empty()
    assert e.filters == () and e.weights.size == 0 and e.batch.dtype == np.int64

"""The machine-steadiness row: one fixed workload timed through a bench run."""

from __future__ import annotations

import pytest

from tools.bench.steadiness import STEADINESS_GOAL, Steadiness, _workload, probe_s


def test_the_row_is_the_slowest_probe_against_the_fastest():
    s = Steadiness()
    s.points = [("filters", 0.020), ("core", 0.021), ("end", 0.0205)]
    row = s.row()
    assert row["name"] == "machine-steadiness" and row["unit"] == "ms CPU"
    assert row["ours"] == pytest.approx(21.0) and row["reference"] == pytest.approx(20.0)
    assert row["ratio"] == pytest.approx(1.05) and row["met"] is True
    assert row["probe_ms"] == {"filters": 20.0, "core": 21.0, "end": 20.5} and row["points"] == 3
    assert row["median_ms"] == pytest.approx(20.5)
    assert row["goal"] == STEADINESS_GOAL.text() == "ratio <= 1.1"


def test_a_machine_that_slowed_down_by_more_than_ten_per_cent_misses_the_goal():
    s = Steadiness()
    s.points = [("filters", 0.020), ("campaigns", 0.0222)]
    row = s.row()
    assert row["ratio"] == pytest.approx(1.11) and row["met"] is False
    s.points = [("end", 0.020)]  # one point: nothing to compare, the machine was as fast as itself
    assert s.row()["ratio"] == 1.0 and s.row()["met"] is True


def test_no_row_without_a_probe():
    with pytest.raises(ValueError):
        Steadiness().row()


def test_the_probe_runs_one_fixed_workload_and_times_it():
    # the same work every time (so its time says how fast the machine is, nothing else)
    assert _workload() == _workload() and _workload(10) != _workload(20)
    s = Steadiness()
    seconds = s.sample("decode")
    assert 0.0 < seconds < 5.0 and s.points == [("decode", seconds)]
    assert probe_s() > 0.0

"""A campaign task: the run the worker receives, with the detector facts its row records."""

from __future__ import annotations

from ground.report.row_types import Cell
from tools.campaign.task import RunTask

TASK = {
    "id": "0123456789abcdef", "cell": {"scenario": "s", "fault": "none", "variant": "three"}, "seed": 4,
    "scenario": {"name": "s", "sim": {"trajectory": {"span_days": 2.0}}}, "fault_label": "none",
    "fault_class": "none", "detector_network": "chi2", "detector_calibrated": True, "span_days": 2.0,
    "extract_weights": ["chi2"], "keep_mcap": "failed", "monitors": {"magill": {"network": "magill", "threshold": 8.0}},
}


def test_task_round_trip_and_detector_facts():
    t = RunTask.from_json(TASK)
    assert t.cell == Cell("s", "none", "three") and t.extract_weights == ("chi2",)
    assert t.to_json() == TASK
    assert t.detector.to_json() == {"network": "chi2", "calibrated": True, "monitors": ["magill"]}
    bare = RunTask.from_json({**TASK, "monitors": {}})
    assert bare.detector.to_json() == {"network": "chi2", "calibrated": True}

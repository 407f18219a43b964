"""The validation report's calibration section: it prints what the calibration record holds."""

from __future__ import annotations

import numpy as np

from tools.calibration.plan import CalibrationPlan
from tools.calibration.record import CalibrationRecord, NetworkCalibration, read_record, write_record
from tools.calibration.thresholds import calibrate, holdout_check
from tools.validation import calibration
from test_fdir_synthetic import BANK3, names, simulate_chi2


def _record(tmp_path):
    train = simulate_chi2(np.random.default_rng(5), BANK3, 99, 30)
    held = simulate_chi2(np.random.default_rng(6), BANK3, 60, 30)
    config, report = calibrate(list(train), 0.05, network="chi2", filters=names(BANK3))
    check = holdout_check(config, report, list(held), BANK3)
    plan = CalibrationPlan(scenario="insight-approach", networks=("chi2",), seeds=99, base_seed=1001, target_fa=0.05,
                           holdout=60, holdout_base_seed=3001)
    rec = CalibrationRecord(plan=plan, generated="2026-11-24", networks=(
        NetworkCalibration(network="chi2", runs=99, report=report, holdout=check, holdout_runs=60, command="x"),))
    path = tmp_path / calibration.file_name("insight-approach")
    write_record(rec, path)
    return rec, path


def test_record_round_trips(tmp_path):
    rec, path = _record(tmp_path)
    assert read_record(path) == rec


def test_section_reports_the_record(tmp_path):
    rec, path = _record(tmp_path)
    s = calibration.section("insight-approach", path, tmp_path / "figures", tmp_path)
    text = "\n".join(s.lines)
    n = rec.networks[0]
    assert "seeds 1001–1099" in text and "seeds 3001–3060" in text and "tools/campaigns/detectors" in text
    assert f"{n.holdout.false_alarms}/60" in text and f"{n.report.false_alarms}/{n.report.units}" in text
    assert f"{n.holdout.predicted[0]}–{n.holdout.predicted[1]}" in text
    assert [c.holds for c in s.claims] == [n.holdout.inside]
    assert (tmp_path / "figures" / "calibration-insight-approach.png").stat().st_size > 1000

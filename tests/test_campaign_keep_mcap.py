"""Campaigns keep per-run MCAP recordings on request (``keep_mcap: failed|detected|all``)."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import pytest

from ground.mcap_io.reader import read_attachments, summary
from ground.report.summary_types import RunSummary
from test_summary_types import DETECTION, RUN_SUMMARY
from tools.campaign.run_mcap import keeps
from tools.campaign.store import read_rows
from tools.cli import main

CAMPAIGN = """\
name: keep
seeds: {{count: 2, base: 1}}
keep_mcap: {keep}
matrix:
  - scenarios: [short.yaml]
    faults: [none]
"""


def _summary(**anomaly) -> RunSummary:
    data = json.loads(RUN_SUMMARY)
    data["anomaly"] = {**data["anomaly"], **anomaly}
    return RunSummary.from_json(data)


def test_which_runs_keep_their_recording():
    missed = _summary()  # a fault was injected, nothing declared
    hit = _summary(**DETECTION)
    wrong = _summary(**{**DETECTION, "correct_class": False})
    nominal_quiet = _summary(onset_true=None, onset_true_day=None, true_class="none")
    false_alarm = _summary(**{**DETECTION, "false_alarm": True, "onset_true": None, "latency_s": None})
    assert [keeps("failed", s) for s in (missed, hit, wrong, nominal_quiet, false_alarm)] == [True, False, True, False, True]
    assert [keeps("detected", s) for s in (missed, hit, wrong, nominal_quiet, false_alarm)] == [False, True, True, False, True]
    assert all(keeps("all", s) for s in (missed, hit, nominal_quiet))
    assert not any(keeps("none", s) for s in (missed, hit, false_alarm))


def test_a_bad_keep_mcap_value_is_one_line(tmp_path, capsys, short_scenario):
    (tmp_path / "short.yaml").write_text(short_scenario())
    (tmp_path / "c.yaml").write_text(CAMPAIGN.format(keep="failures"))
    assert main(["campaign", str(tmp_path / "c.yaml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "keep_mcap: expected one of none, failed, detected, all" in err and "did you mean 'failed'" in err


@pytest.mark.slow
def test_keep_mcap_all_records_every_run_for_report_and_rerun(tmp_path, short_scenario):
    (tmp_path / "short.yaml").write_text(short_scenario())
    (tmp_path / "c.yaml").write_text(CAMPAIGN.format(keep="all"))
    out = tmp_path / "out"
    cli = [sys.executable, "-m", "tools.cli"]
    proc = subprocess.run([*cli, "campaign", str(tmp_path / "c.yaml"), "--workers", "1", "--out", str(out)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = read_rows(out / "runs.jsonl").rows
    assert len(rows) == 2
    for row in rows:
        mcap = out / "mcap" / f"{row.id}.mcap"
        counts = summary(mcap)
        assert counts["/sim/measurements"] == row.summary.measurements.published
        assert "config.yaml" in read_attachments(mcap)
    # the FSW re-run from a kept recording reproduces it (work-unit budget: deterministic)
    mcap = out / "mcap" / f"{rows[0].id}.mcap"
    rerun = subprocess.run([*cli, "replay", str(mcap), "--rerun"], capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stdout[-2000:] + rerun.stderr[-2000:]
    assert "result: IDENTICAL" in rerun.stdout

"""``navbank replay --rerun --out DIR``: the re-run as a run that ``report`` reads and that
re-runs identically; ISO dates in the diff; a warning when a calibrated detector's network changed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ground.mcap_io.reader import read_attachments, summary
from ground.replay.regression import calibration_notes
from ground.replay.fsw_config import load_fsw_config
from tools.cli import main

GOLDEN = Path(__file__).resolve().parent / "golden" / "insight-4day.mcap"
GOLDEN_CONFIG = GOLDEN.with_suffix(".yaml")


@pytest.fixture(scope="module")
def rerun_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("rerun") / "changed"
    return out


def test_rerun_out_writes_a_run_that_report_reads_and_reruns_identically(rerun_dir, capsys):
    code = main(["replay", str(GOLDEN), "--rerun", "--set", "fsw.gating[0].batch_size=200", "--out", str(rerun_dir)])
    text = capsys.readouterr().out
    assert code == 1  # the change shows up
    assert re.search(r"\(20\d\d-\d\d-\d\dT\d\d:\d\d:\d\d UTC, t_s \d+\.\d\)", text), text[-1500:]
    # epochs in the examples are dates too, never raw TDB seconds
    declared = next(ln for ln in text.splitlines() if "/fsw/anomaly declared_s:" in ln)
    assert re.search(r"e\.g\. None vs 20\d\d-\d\d-\d\dT\d\d:\d\d:\d\d at", declared), declared
    assert "the detector's calibration was made for chi2 as recorded; this re-run changes batch_size 300 -> 200" in text
    mcap = rerun_dir / "run.mcap"
    # the recorded ground side is kept, the FSW side is the re-run's
    before, after = summary(GOLDEN), summary(mcap)
    for topic in ("/sim/measurements", "/sim/truth", "/sim/faults", "/sim/status"):
        assert after[topic] == before[topic], topic
    assert after["/fsw/weights/chi2"] != before["/fsw/weights/chi2"]
    config = (rerun_dir / "config.yaml").read_text()
    assert "batch_size: 200" in config
    assert read_attachments(mcap)["config.yaml"][1].decode() == config
    # a re-run of the re-run reproduces it bit for bit
    assert main(["replay", str(mcap), "--rerun"]) == 0
    assert "result: IDENTICAL" in capsys.readouterr().out
    pytest.importorskip("matplotlib")
    assert main(["report", str(rerun_dir)]) == 0
    assert (rerun_dir / "report" / "report.md").is_file()


def test_no_warning_without_a_change_to_the_watched_network():
    text = GOLDEN_CONFIG.read_text()
    recorded = load_fsw_config(text, "g")
    assert calibration_notes(recorded, recorded) == []
    other = load_fsw_config(text, "g", overrides=["fsw.gating[2].lower_bound=1.0e-9"])  # magill, not watched
    assert calibration_notes(recorded, other) == []
    watched = load_fsw_config(text, "g", overrides=["fsw.gating[0].batch_size=200"])
    assert len(calibration_notes(recorded, watched)) == 1

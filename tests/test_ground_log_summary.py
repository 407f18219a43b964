"""``navbank ground log --summary``: its options, and when the logger writes the run's summary."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from ground.logger import LogResult, _parse_json
from ground.report.summary_feed import SummaryFeed
from tools.commands.errors import UsageError
from tools.commands.ground import _write_fed_summary, summary_context

ROOT = Path(__file__).resolve().parents[1]
GOOD = {"scenario": "insight-approach", "seed": 3, "fault": None, "t0": 1.5}


def test_the_context_is_read_and_checked():
    assert summary_context(json.dumps(GOOD)) == GOOD
    assert summary_context(json.dumps(dict(GOOD, t0=2))) == dict(GOOD, t0=2.0)
    assert summary_context(json.dumps(dict(GOOD, fault="optical-measurement")))["fault"] == "optical-measurement"
    bad = ["{", "[]", json.dumps({"scenario": "x"}), json.dumps(dict(GOOD, extra=1)), json.dumps(dict(GOOD, seed=True)),
           json.dumps(dict(GOOD, seed=1.5)), json.dumps(dict(GOOD, fault=3)), json.dumps(dict(GOOD, scenario=None)),
           '{"scenario": "x", "seed": 1, "fault": null, "t0": NaN}']
    for text in bad:
        with pytest.raises(UsageError, match="--summary-context"):
            summary_context(text)


@pytest.mark.parametrize("extra", [["--summary", "S"], ["--summary-context", json.dumps(GOOD)],
                                   ["--summary", "S", "--summary-context", '{"seed": 1}']])
def test_a_bad_summary_option_is_one_line_and_exit_2(tmp_path, extra):
    extra = [str(tmp_path / "s.json") if a == "S" else a for a in extra]
    out = subprocess.run([sys.executable, "-m", "tools.cli", "ground", "log", "--run-id", "r1", "--out",
                          str(tmp_path / "r.mcap"), *extra], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "--summary" in lines[0], out.stderr
    assert not (tmp_path / "r.mcap").exists()


def _fed() -> SummaryFeed:
    from mcap.reader import make_reader
    from fsw.interface import topics

    feed = SummaryFeed()
    with open(ROOT / "tests" / "golden" / "insight-4day.mcap", "rb") as f:
        for _, channel, message in make_reader(f).iter_messages(log_time_order=False):
            topic = channel.topic.lstrip("/")
            try:
                cls = topics.type_of_topic(topic)
            except KeyError:
                continue
            feed(topic, cls, bytes(message.data), _parse_json(message.data), message.log_time)
    return feed


def test_the_summary_is_written_only_for_a_run_recorded_whole(tmp_path, capsys):
    feed = _fed()
    path = tmp_path / "s.json"
    _write_fed_summary(feed, GOOD, path, LogResult(str(tmp_path / "r.mcap"), "end-of-run", 1.0), segment=False)
    assert json.loads(path.read_text()) == {"summary": json.loads(json.dumps(feed.summarize(**GOOD).to_json())),
                                            "logger": {"duplicates": {}, "gaps": {}}}
    counted = LogResult(str(tmp_path / "r.mcap"), "end-of-run", 1.0, duplicates={"sim/measurements": 2},
                        gaps={"fsw/status": 1})
    _write_fed_summary(feed, GOOD, path, counted, segment=False)
    assert json.loads(path.read_text())["logger"] == {"duplicates": {"sim/measurements": 2}, "gaps": {"fsw/status": 1}}
    assert capsys.readouterr().err == ""
    for ended_by, segment, why in (("duration", False, "ended by duration"), ("signal", False, "ended by signal"),
                                   ("end-of-run", True, "later segment")):
        path.write_text("{}")  # an earlier run's: never left standing
        _write_fed_summary(feed, GOOD, path, LogResult(str(tmp_path / "r.mcap"), ended_by, 1.0), segment=segment)
        assert not path.exists()
        err = capsys.readouterr().err
        assert "no summary written" in err and why in err


def test_a_spoilt_feed_writes_no_summary(tmp_path, capsys):
    from fsw.interface.messages import BudgetReport

    feed = SummaryFeed()
    feed("fsw/budget", BudgetReport, b"{}", {}, 1)
    path = tmp_path / "s.json"
    _write_fed_summary(feed, GOOD, path, LogResult(str(tmp_path / "r.mcap"), "end-of-run", 1.0), segment=False)
    assert not path.exists()
    err = capsys.readouterr().err
    assert "no summary written" in err and "/fsw/budget" in err


def test_navbank_run_takes_the_logger_summary_once_or_reads_the_recording_back(tmp_path, capsys):
    from tools.commands.run import _logger_summary

    feed = _fed()
    path = tmp_path / "ground-summary.json"
    counted = LogResult(str(tmp_path / "r.mcap"), "end-of-run", 1.0, gaps={"fsw/status": 1})
    _write_fed_summary(feed, GOOD, path, counted, segment=False)
    summary, logged = _logger_summary(path)
    assert summary == feed.summarize(**GOOD) and logged == {"duplicates": {}, "gaps": {"fsw/status": 1}}
    assert not path.exists()  # taken: summary.json is the run's
    assert _logger_summary(path) is None and capsys.readouterr().err == ""
    for spoilt in ("{", '{"summary": {}}', '{"summary": {"seed": "x"}, "logger": {}}', '{"summary": 1, "logger": []}'):
        path.write_text(spoilt)
        assert _logger_summary(path) is None
        assert "reading the recording back" in capsys.readouterr().err
        assert not path.exists()

"""A real `navbank campaign` process: Ctrl-C, resume without redoing runs, failed runs, --rerun-failed."""

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest

from tools.campaign.store import read_rows

# the `broken` variant fails at run time (the entry epoch is only parsed when the run starts); its
# block comes last so that the interruptions below land on runs that take a few seconds
CAMPAIGN = """\
name: resume
seeds: {count: 4, base: 1}
onset_day: 1.0
matrix:
  - scenarios: [short.yaml]
    faults: [none, optical-bias-medium]
  - scenarios: [short.yaml]
    faults: [none, optical-bias-medium]
    networks:
      - name: broken
        overrides: {sim.trajectory.entry_epoch_utc: "2018-13-45T00:00:00"}
"""
# four seeds: the first interruptions land in the ok block (its runs take seconds) even when a
# loaded machine lets a few more rows through before a signal is acted on
TOTAL, OK, FAILED = 16, 8, 8


def _start(tmp_path: Path, *extra: str) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "tools.cli", "campaign", str(tmp_path / "c.yaml"), "--workers", "1",
           "--out", str(tmp_path / "out"), *extra]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)


def _rows(tmp_path: Path):
    return read_rows(tmp_path / "out" / "runs.jsonl")


def _wait_rows(tmp_path: Path, proc: subprocess.Popen, n: int, timeout_s: float = 180.0) -> None:
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        if len(_rows(tmp_path).rows) >= n:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.2)
    proc.kill()
    pytest.fail(f"fewer than {n} rows after {timeout_s} s")


def _check_whole_lines(tmp_path: Path) -> None:
    data = (tmp_path / "out" / "runs.jsonl").read_bytes()
    assert data.endswith(b"\n")
    for line in data.splitlines():
        json.loads(line)


@pytest.mark.slow
def test_interrupt_resume_failures_and_rerun_failed(tmp_path, short_scenario):
    # 20 days: a run must take a few seconds for the signals below to land while one flies (the
    # compiled FSW flies the default two days in well under a second)
    (tmp_path / "short.yaml").write_text(short_scenario(span_days=20.0))
    (tmp_path / "c.yaml").write_text(CAMPAIGN)

    # 1. one Ctrl-C: stop submitting, let the running run finish, exit 130
    proc = _start(tmp_path, "--quiet")
    _wait_rows(tmp_path, proc, 2)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err
    first = _rows(tmp_path).rows
    assert 2 <= len(first) < TOTAL
    _check_whole_lines(tmp_path)

    # 2. resume, then two Ctrl-C: the running run is cancelled and gets no row
    proc = _start(tmp_path)
    _wait_rows(tmp_path, proc, len(first) + 1)  # the next run has just started and takes seconds
    assert len(_rows(tmp_path).rows) < OK, "the run to cancel is not one of the ok block's"
    proc.send_signal(signal.SIGINT)
    time.sleep(0.3)
    assert proc.poll() is None
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert json.loads(out.strip().splitlines()[-1])["cancelled"] == 1
    second = _rows(tmp_path).rows
    assert len(second) < OK
    _check_whole_lines(tmp_path)

    # 3. resume to the end: every run exactly once, the failures recorded and not fatal
    proc = _start(tmp_path, "--quiet")
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 1, err  # finished, with failed runs
    result = json.loads(out.strip().splitlines()[-1])
    assert result["skipped"] == len(second) and result["finished"] == TOTAL - len(second)
    rows = _rows(tmp_path).rows
    counts = Counter(r.id for r in rows)
    assert len(counts) == TOTAL and set(counts.values()) == {1}, "a finished run was done twice"
    plan = json.loads((tmp_path / "out" / "plan.json").read_text())
    assert set(counts) == {r["id"] for r in plan["runs"]}
    failed = [r for r in rows if r.status == "failed"]
    assert len(failed) == FAILED and {r.cell.variant for r in failed} == {"broken"}
    for r in failed:
        assert r.error.type == "TruthTimeError" and "2018-13-45" in r.error.message
        assert "Traceback" in r.error.traceback or "Error" in r.error.traceback
        assert r.seed in (1, 2, 3, 4)
    assert sum(r.status == "ok" for r in rows) == OK
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["runs"] == summary["runs"] | {"ok": OK, "failed": FAILED, "missing": 0}
    assert "## Failed runs" in (tmp_path / "out" / "report.md").read_text()

    # 4. the same command again runs nothing
    proc = _start(tmp_path, "--quiet")
    out, err = proc.communicate(timeout=120)
    assert json.loads(out.strip().splitlines()[-1])["finished"] == 0
    assert len(_rows(tmp_path).rows) == TOTAL

    # 5. --rerun-failed runs the failed ids again, and only them
    proc = _start(tmp_path, "--quiet", "--rerun-failed")
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err
    rows = _rows(tmp_path).rows
    counts = Counter(r.id for r in rows)
    failed_ids = {r.id for r in failed}
    assert all(counts[i] == 2 for i in failed_ids)
    assert all(c == 1 for i, c in counts.items() if i not in failed_ids)
    assert os.path.getsize(tmp_path / "out" / "runs.jsonl") > 0

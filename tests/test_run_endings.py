"""How `navbank run` ends when it does not complete: interrupted runs leave a summary that says
so, and a killed launcher leaves no orphaned processes."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.slow

LONG = """\
name: long-enough
seed: 4
sim:
  trajectory: {span_days: 20.0}
fsw:
  budget: {mode: work-units}
"""


# The run must still be going when it is stopped: the simulator is paced to ~40 s for 20 days
# (the FSW flies the same arc in a few seconds of CPU).
RATE = 20 * 86400 / 40.0


def _start(tmp_path, run_id: str) -> subprocess.Popen:
    (tmp_path / "s.yaml").write_text(LONG)
    return subprocess.Popen([sys.executable, "-m", "tools.cli", "run", "--scenario", str(tmp_path / "s.yaml"),
                             "--out", str(tmp_path / "out"), "--run-id", run_id, "--rate", f"{RATE:g}"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for_progress(proc: subprocess.Popen, timeout_s: float = 60.0) -> None:
    """Until the FSW reports progress (the three processes are up and data flows)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        # the progress bar's line (a pipe gets whole lines): "run ID  12%|#  | 5.3/45.0 day [..."
        day = re.search(r"\| ([0-9.]+)/[0-9.]+ day \[", line)
        if day and float(day.group(1)) > 0.0 and "processed" in line:
            return
        assert line or proc.poll() is None, "navbank run ended early"
    raise AssertionError("no progress")


def _processes_of(run_id: str) -> list[int]:
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().split(b"\0")
        except OSError:
            continue
        if run_id.encode() in cmd and int(pid) != os.getpid():
            out.append(int(pid))
    return out


def test_sigint_stops_the_run_and_leaves_an_interrupted_summary(tmp_path):
    proc = _start(tmp_path, "endings-int")
    try:
        _wait_for_progress(proc)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["reason"]
    assert "status: interrupted" in out
    # the FSW said how far it got as it stopped, and the logger (stopped last) recorded it
    from ground.mcap_io.reader import read_messages

    statuses = [r.message for r in read_messages(tmp_path / "out" / "run.mcap", topics=["/fsw/status"])]
    last = statuses[-1]
    assert last.state == "error" and last.message == "stopped (signal)"
    assert last.counts["processed"] > 0 and summary["measurements"]["processed"] == last.counts["processed"]
    assert _processes_of("endings-int") == []


def test_a_killed_launcher_leaves_no_orphans(tmp_path):
    proc = _start(tmp_path, "endings-kill")
    try:
        _wait_for_progress(proc)
        children = _processes_of("endings-kill")
        assert len(children) >= 3  # the launcher and its three processes
        proc.kill()
        proc.wait(10)
        deadline = time.monotonic() + 5.0
        while _processes_of("endings-kill") and time.monotonic() < deadline:
            time.sleep(0.1)
        left = _processes_of("endings-kill")
    finally:
        for pid in _processes_of("endings-kill"):
            os.kill(pid, signal.SIGKILL)
    assert left == [], f"still running 5 s after the launcher was killed: {left}"


@pytest.mark.parametrize("rate", ["0", "-5", "nan", "inf"])
def test_a_bad_rate_is_one_line_exit_2(tmp_path, rate):
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "run", "--rate", rate, "--out", str(tmp_path / "o"),
                           "--quiet"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == "navbank run: --rate must be a number > 0"
    assert not (tmp_path / "o").exists()  # refused before anything started

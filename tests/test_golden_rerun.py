"""Behaviour pinned by recordings: the committed golden runs re-fly to IDENTICAL FSW telemetry.

The recordings were made with ``navbank run`` (three processes over Zenoh) in work-unit budget
mode, so every /fsw message is a deterministic function of the recorded measurements and the
configuration attached to the file. A refactoring that changes any of them — a weight, an
estimate, a budget report, the anomaly declaration — fails here.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

GOLDEN = Path(__file__).resolve().parent / "golden"


@pytest.mark.parametrize("name", ["insight-4day", "thrusters-4day"])
def test_golden_recording_reruns_identical(name):
    path = GOLDEN / f"{name}.mcap"
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "replay", str(path), "--rerun"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "result: IDENTICAL (tolerance 0)" in proc.stdout
    # the recording really carries the behaviour it is meant to pin
    assert "/fsw/anomaly" in proc.stdout and "/fsw/budget" in proc.stdout

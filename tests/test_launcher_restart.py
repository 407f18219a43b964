"""What the launcher restarts, and with which options (the drills are in test_restart_e2e.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tools.launcher import Child, _died, _restart_arguments, segment_path


def _child(tmp_path: Path, code: str, tail: list[str]) -> Child:
    proc = subprocess.Popen([sys.executable, "-c", code])
    proc.wait(timeout=30)
    return Child("fsw", proc, tmp_path / "fsw.log", tail=tail)


@pytest.mark.parametrize("code, tail, died", [
    ("import os, signal; os.kill(os.getpid(), signal.SIGKILL)", ["fsw: day 1.0 processed 10"], True),
    ("raise RuntimeError('boom')", ["Traceback (most recent call last):", '  File "x", line 1', "RuntimeError: boom"], True),
    ("raise SystemExit(3)", [], True),
    ("raise SystemExit(1)", ["navbank ground log: run.mcap: cannot write: [Errno 28] No space left on device"], False),
    ("raise SystemExit(2)", ["navbank fsw: fsw.ckpt: checkpoint of another FSW configuration"], False),
])
def test_only_a_process_that_died_is_restarted_not_one_that_said_why_it_failed(tmp_path, code, tail, died):
    assert _died(_child(tmp_path, code, tail)) is died


def test_a_restarted_fsw_resumes_from_the_checkpoint(tmp_path):
    assert _restart_arguments("fsw", tmp_path, 1) == ("--resume", str(tmp_path / "fsw.ckpt"))


def test_a_restarted_logger_writes_the_next_segment_after_the_earlier_ones(tmp_path):
    (tmp_path / "run.mcap").write_bytes(b"first logger's file")
    first = _restart_arguments("ground", tmp_path, 1)
    assert not (tmp_path / "run.mcap").exists()
    assert segment_path(tmp_path, 0).read_bytes() == b"first logger's file"
    assert first == ("--out", str(segment_path(tmp_path, 1)), "--after", str(segment_path(tmp_path, 0)))
    segment_path(tmp_path, 1).write_bytes(b"second")
    assert _restart_arguments("ground", tmp_path, 2) == (
        "--out", str(segment_path(tmp_path, 2)),
        "--after", str(segment_path(tmp_path, 0)), "--after", str(segment_path(tmp_path, 1)))


def test_a_reused_output_directory_hands_the_run_no_old_checkpoint_or_segments(tmp_path, monkeypatch):
    import tools.launcher as launcher

    out = tmp_path / "out"
    out.mkdir()
    for name in ("fsw.ckpt", "run.seg0.mcap", "run.seg1.mcap"):
        (out / name).write_bytes(b"from an earlier run")

    def no_ports(n: int) -> list[int]:
        raise RuntimeError("stop here: only the preparation is under test")

    monkeypatch.setattr(launcher, "free_tcp_ports", no_ports)
    from tools.scenario import load_text_scenario, resolve

    cfg, _ = resolve(load_text_scenario("name: x\nsim:\n  trajectory: {span_days: 1.0}\n"), 1)
    with pytest.raises(RuntimeError, match="stop here"):
        launcher.launch(cfg, "reused", out)
    assert sorted(p.name for p in out.iterdir()) == ["config.yaml"]

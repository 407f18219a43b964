"""Processes of one run started by hand find each other on one host without endpoint options."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ground.foxglove.records import is_derived
from ground.mcap_io.reader import summary
from tools import rendezvous

GOLDEN = Path(__file__).resolve().parent / "golden" / "insight-4day.mcap"


def _args(**given) -> argparse.Namespace:
    base = dict(listen=None, connect=None, client=False, zenoh_config=None, no_gossip=False, connect_timeout=10.0)
    return argparse.Namespace(**{**base, **given})


@pytest.fixture
def runtime(tmp_path, monkeypatch) -> Path:
    base = tmp_path / "xdg"
    base.mkdir(mode=0o700)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(base))
    return base / "navbank"


def test_announced_while_running_withdrawn_after_and_found_by_run_id(runtime, capsys):
    with rendezvous.joined(_args(), "run-a", "ground", name="ground log") as cfg:
        (ep,) = cfg.listen
        assert ep.startswith("tcp/127.0.0.1:") and not ep.endswith(":0") and cfg.connect == ()
        files = list((runtime / "run-a").glob("ground-*.json"))
        assert len(files) == 1 and json.loads(files[0].read_text())["endpoint"] == ep
        # another process of the run finds it; another run does not
        others = rendezvous.endpoints("run-a")
        assert others == []  # our own file is not a peer of ours
        with rendezvous.joined(_args(), "run-b", "replay", announce=False) as other_run:
            assert other_run.connect == ()
    assert f"ground log: run run-a listening on {ep}" in capsys.readouterr().err
    assert not (runtime / "run-a").exists()


def test_a_process_that_is_gone_is_ignored_and_its_file_removed(runtime):
    runtime.mkdir(mode=0o700)
    run_dir = runtime / "run-c"
    run_dir.mkdir(mode=0o700)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = run_dir / "ground-1.json"
    stale.write_text(json.dumps({"endpoint": "tcp/127.0.0.1:9", "pid": int(dead.stdout)}))
    live = run_dir / "fsw-2.json"
    live.write_text(json.dumps({"endpoint": "tcp/127.0.0.1:7", "pid": os.getppid()}))
    assert rendezvous.endpoints("run-c") == ["tcp/127.0.0.1:7"]
    assert not stale.exists()


def test_a_directory_open_to_others_is_not_trusted(runtime):
    runtime.mkdir(mode=0o755)
    runtime.chmod(0o755)
    assert rendezvous.runtime_dir() is None
    with rendezvous.joined(_args(), "run-d", "sim") as cfg:  # still runs, on a port of its own
        assert cfg.listen[0].startswith("tcp/127.0.0.1:") and cfg.connect == ()


def test_given_options_are_used_as_they_are(runtime):
    with rendezvous.joined(_args(connect=["tcp/127.0.0.1:7447"]), "run-e", "replay") as cfg:
        assert cfg.connect == ("tcp/127.0.0.1:7447",) and cfg.listen == ("tcp/127.0.0.1:0",)
    assert not (runtime / "run-e").exists()


@pytest.mark.slow
def test_ground_log_and_replay_by_hand_with_no_endpoint_options(tmp_path):
    xdg = tmp_path / "xdg"
    xdg.mkdir(mode=0o700)
    env = dict(os.environ, XDG_RUNTIME_DIR=str(xdg))
    out = tmp_path / "f.mcap"
    cmd = [sys.executable, "-m", "tools.cli"]
    logger = subprocess.Popen([*cmd, "ground", "log", "--run-id", "byhand", "--out", str(out)], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not list((xdg / "navbank" / "byhand").glob("ground-*.json")):
            assert logger.poll() is None and time.monotonic() < deadline, "the logger did not announce itself"
            time.sleep(0.1)
        replay = subprocess.run([*cmd, "replay", str(GOLDEN), "--run-id", "byhand", "--consumers", "ground", "--fast"],
                                env=env, capture_output=True, text=True, timeout=180)
        assert replay.returncode == 0, replay.stderr[-2000:]
        assert "consumer ground: confirmed every message" in replay.stdout
        _, err = logger.communicate(timeout=60)
    finally:
        if logger.poll() is None:
            logger.kill()
            logger.communicate()
    assert logger.returncode == 0, err[-2000:]
    assert "ground log: run byhand listening on tcp/127.0.0.1:" in err
    recorded, original = summary(out), summary(GOLDEN)
    assert recorded.pop("/ground/status") == 1
    # the logger adds its Foxglove view (scene, transforms, log, plot channels) made from the ICD record
    assert any(is_derived(t) for t in recorded)
    recorded = {t: n for t, n in recorded.items() if not is_derived(t)}
    assert recorded == original
    assert not (xdg / "navbank" / "byhand").exists()

"""`navbank replay` on a real recorded run: republish to a second logger, re-run the FSW and diff."""

from __future__ import annotations

import json
import multiprocessing as mp
import subprocess
import sys

import pytest

from fsw import transport as T
from fsw.interface import codec
from fsw.interface import messages as m
from ground.logger import run_logger
from ground.replay.recording import iter_raw

CTX = mp.get_context("spawn")

pytestmark = pytest.mark.slow


def _navbank(*args: str, timeout: float = 180) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tools.cli", *args], capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory, short_e2e_yaml):
    d = tmp_path_factory.mktemp("replay")
    # the end-to-end scenario in the deterministic work-unit budget mode
    (d / "short.yaml").write_text(short_e2e_yaml + "  budget: {mode: work-units}\n")
    proc = _navbank("run", "--scenario", str(d / "short.yaml"), "--out", str(d / "out"), "--quiet", timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return d / "out" / "run.mcap"


def _by_topic(path) -> dict[str, list[bytes]]:
    out: dict[str, list] = {}
    for msg in iter_raw(path):
        out.setdefault(msg.topic, []).append(msg)
    return {t: [x.data for x in sorted(v, key=lambda x: x.sequence)] for t, v in out.items()}


def _logger(cfg, run_id, path, out, ready) -> None:
    res = run_logger(run_id, path, cfg, producers=("replay",), ready_event=ready, max_duration_s=120, print_fn=None)
    out.put((res.ended_by, res.counts, res.gaps, res.finished))


def test_replay_to_a_second_logger_reproduces_every_payload(recorded, tmp_path):
    port = T.free_tcp_ports(1)[0]
    ep = f"tcp/127.0.0.1:{port}"
    second = tmp_path / "second.mcap"
    out, ready = CTX.Queue(), CTX.Event()
    logger = CTX.Process(target=_logger, args=(T.TransportConfig(listen=(ep,)), "replayed-1", str(second), out, ready))
    logger.start()
    try:
        assert ready.wait(30)
        proc = _navbank("replay", str(recorded), "--run-id", "replayed-1", "--rate", "50", "--consumers", "ground",
                        "--connect", ep, timeout=120)
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert "consumer ground: confirmed every message" in proc.stdout
        ended_by, counts, gaps, finished = out.get(timeout=60)
        logger.join(30)
    finally:
        if logger.is_alive():
            logger.kill()
    assert ended_by == "end-of-run" and finished == ("replay",) and gaps == {}
    first, again = _by_topic(recorded), _by_topic(second)
    # the second file holds exactly the first one's messages plus the replay's end-of-run status
    status = again.pop("/ground/status")
    assert first.pop("/ground/status", []) == status[:-1]
    end = codec.from_json(m.RunStatus, status[-1])
    assert end.source == "replay" and end.state == "end-of-run" and end.run_id == "replayed-1"
    assert {t: len(v) for t, v in again.items()} == {t: len(v) for t, v in first.items()}
    assert {"/" + k: v for k, v in end.counts.items() if "/" in k and v} == {t: len(v) for t, v in first.items()}
    for topic in first:
        assert again[topic] == first[topic], topic  # byte-identical payloads, same order
    assert len(first["/sim/measurements"]) > 2000


def test_rerun_of_an_unchanged_fsw_is_identical(recorded, tmp_path):
    report = tmp_path / "cmp.json"
    proc = _navbank("replay", str(recorded), "--rerun", "--json", str(report))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "result: IDENTICAL (tolerance 0)" in proc.stdout
    cmp = json.loads(report.read_text())
    assert cmp["identical"]
    assert {"/fsw/weights/chi2", "/fsw/weights/magill", "/fsw/estimate/combined", "/fsw/budget", "/fsw/status"} <= set(cmp["topics"])
    for topic, t in cmp["topics"].items():
        assert t["compared"] and t["recorded"] == t["rerun"] > 0, topic
        assert t["max_abs"] == 0.0 and t["mismatches"] == 0, topic


def test_rerun_with_a_changed_parameter_reports_the_difference(recorded, tmp_path):
    report = tmp_path / "cmp.json"
    proc = _navbank("replay", str(recorded), "--rerun", "--set", "fsw.gating[0].sigma_w=0.1", "--json", str(report))
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "result: DIFFERENT" in proc.stdout and "--set fsw.gating[0].sigma_w=0.1" in proc.stdout
    cmp = json.loads(report.read_text())
    chi2 = cmp["topics"]["/fsw/weights/chi2"]
    assert chi2["recorded"] == chi2["rerun"]  # same batches, different weights
    assert chi2["fields"]["weights"]["max_abs"] > 1e-4
    assert cmp["topics"]["/fsw/estimate/combined"]["max_abs"] > 0.0  # combined with the chi2 weights
    # magill does not depend on the chi2 memory: untouched
    assert cmp["topics"]["/fsw/weights/magill"]["max_abs"] == 0.0
    # a bad value is one line and exit code 2
    bad = _navbank("replay", str(recorded), "--rerun", "--set", "fsw.gating[0].sigma_w=-1")
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1, bad.stderr

"""Supervised restarts, end to end: real `navbank run` processes over real Zenoh, real MCAP read back.

The drills: kill -9 of the FSW at ~30 % and ~70 % of a short work-unit run → the run completes,
nothing is lost, the restart is in summary.json, and the FSW's telemetry is identical to that of
an unkilled run; kill -9 of the logger → the run completes and its recording reads with the
plain `mcap` reader; SIGINT → an interrupted summary that counts what was delivered but not
processed. Processes are found by the run id on their command line, and killed by pid.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from fsw.core.checkpoint import CheckpointError, read_header
from ground.foxglove.records import is_derived
from ground.mcap_io.reader import read_messages
from fsw.interface import codec
from fsw.interface.messages import RunStatus

pytestmark = pytest.mark.slow

#: Eight days of the short approach slice (about 4 800 measurements): long enough that at 30 %
#: the simulator is still inside its credit window (the restart is heard of by the window) and
#: at 70 % it may have sent everything (heard of in the end-of-stream drain).
SCENARIO = """\
name: restart-drill
seed: 3
sim:
  trajectory: {span_days: 8.0}
  faults:
    - {type: optical-bias, onset_day: 3.0, sample_px: 20.0, line_px: 30.0}
fsw:
  budget: {mode: work-units}
  checkpoint: {every_measurements: 250}
  gating:
    - {network: chi2, batch_size: 300}
    - {network: magill}
"""


def _start(tmp_path: Path, name: str, *extra: str) -> tuple[subprocess.Popen, Path, str]:
    scen = tmp_path / "drill.yaml"
    scen.write_text(SCENARIO)
    out = tmp_path / name
    run_id = f"drill-{name}-{os.getpid()}"
    proc = subprocess.Popen([sys.executable, "-m", "tools.cli", "run", "--scenario", str(scen), "--out", str(out),
                             "--run-id", run_id, "--quiet", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return proc, out, run_id


def _finish(proc: subprocess.Popen, timeout_s: float = 150.0) -> tuple[str, str]:
    try:
        return proc.communicate(timeout=timeout_s)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _pid_of(run_id: str, role: str) -> int:
    """The process of ``role`` (``python -m tools.cli <role> ... --run-id <run_id>``)."""
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().split(b"\0")
        except OSError:
            continue
        if run_id.encode() in cmd and len(cmd) > 3 and cmd[3] == role.encode():
            return int(pid)
    raise AssertionError(f"no {role} process of run {run_id}")


def _wait_for_checkpoint(out: Path, at_least: int, timeout_s: float = 90.0) -> int:
    """Until the FSW's checkpoint has taken ``at_least`` measurements; returns how many it has."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            taken = read_header(out / "fsw.ckpt").measurements_taken
            if taken >= at_least:
                return taken
        except CheckpointError:
            pass  # not written yet
        time.sleep(0.005)
    raise AssertionError(f"the FSW did not reach {at_least} measurements")


def _fsw_telemetry(mcap: Path, run_id: str) -> dict[str, list[bytes]]:
    """Every /fsw message (and the measurements) as encoded, the run id and the statuses'
    authentication tags (a fresh nonce each time) taken out."""
    out: dict[str, list[bytes]] = {}
    for rec in read_messages(mcap):
        if rec.topic.startswith("/fsw/") or rec.topic == "/sim/measurements":
            msg = dataclasses.replace(rec.message, auth=None) if isinstance(rec.message, RunStatus) else rec.message
            out.setdefault(rec.topic, []).append(codec.to_json(msg).replace(run_id.encode(), b"RUN"))
    return out


@pytest.fixture(scope="module")
def unkilled(tmp_path_factory):
    d = tmp_path_factory.mktemp("unkilled")
    proc, out, run_id = _start(d, "unkilled")
    stdout, stderr = _finish(proc)
    assert proc.returncode == 0, stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    return summary, _fsw_telemetry(out / "run.mcap", run_id)


@pytest.mark.parametrize("fraction", [0.3, 0.7])
def test_a_killed_fsw_is_restarted_and_the_run_is_as_if_it_had_not_died(tmp_path, unkilled, fraction):
    base_summary, base = unkilled
    total = base_summary["measurements"]["published"]
    proc, out, run_id = _start(tmp_path, f"kill{int(fraction * 100)}")
    at = _wait_for_checkpoint(out, int(fraction * total))
    victim = _pid_of(run_id, "fsw")
    os.kill(victim, signal.SIGKILL)
    stdout, stderr = _finish(proc)
    assert proc.returncode == 0, stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())

    events = summary["restarts"]["events"]
    print(f"\nkilled the FSW (pid {victim}) at checkpoint {at} of {total}; restarts: {events}")
    print(f"duplicates dropped by the logger: {summary['restarts']['duplicates_dropped']}; "
          f"gaps: {summary['restarts']['gaps']}")
    assert summary["status"] == "complete"
    assert [e["process"] for e in events] == ["fsw"] and events[0]["exit_code"] == -signal.SIGKILL
    assert events[0]["checkpoint_measurements"] >= at
    assert 0 < events[0]["checkpoint_day"] < 8.0
    m = summary["measurements"]
    assert m["published"] == m["processed"] == total and m["lost"] == 0 and m["rejected"] == 0
    assert summary["restarts"]["gaps"] == {}
    # what came after the checkpoint was sent again (the simulator says how many) and recorded once
    assert events[0]["resent"] > 0
    assert summary["restarts"]["duplicates_dropped"]["sim/measurements"] == events[0]["resent"]

    again = _fsw_telemetry(out / "run.mcap", run_id)
    assert sorted(again) == sorted(base)
    for topic in base:
        assert again[topic] == base[topic], f"{topic} differs from the unkilled run"
    print("identical to the unkilled run: " + ", ".join(f"{t} {len(v)}" for t, v in sorted(base.items())))
    for key in ("anomaly", "gating", "position_error_rms_km", "budget"):
        assert summary[key] == base_summary[key], key


def test_a_killed_logger_is_restarted_and_the_recording_reads_with_the_plain_mcap_reader(tmp_path, unkilled):
    base_summary, _ = unkilled
    total = base_summary["measurements"]["published"]
    proc, out, run_id = _start(tmp_path, "killlogger")
    _wait_for_checkpoint(out, total // 2)
    os.kill(_pid_of(run_id, "ground"), signal.SIGKILL)
    stdout, stderr = _finish(proc)
    assert proc.returncode == 0, stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    restarts = summary["restarts"]
    print(f"\nlogger restarts: {restarts['events']}\nsegments: {restarts['segments']}\ngaps: {restarts['gaps']}")
    assert summary["status"] == "complete"
    assert [e["process"] for e in restarts["events"]] == ["ground"]
    assert [Path(s["file"]).name for s in restarts["segments"]] == ["run.seg0.mcap", "run.seg1.mcap"]
    assert restarts["segments"][0]["complete"] is False and restarts["segments"][1]["complete"] is True

    # the merged file is complete: the plain reader, through its summary, reads every message
    counts: dict[str, int] = {}
    with open(out / "run.mcap", "rb") as f:
        reader = make_reader(f)
        stats = reader.get_summary().statistics
        for _, channel, message in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if not is_derived(channel.topic):  # the Foxglove view's channels are protobuf
                json.loads(message.data)
    assert sum(counts.values()) == stats.message_count == sum(s["messages"] for s in restarts["segments"])
    print(f"plain mcap reader: {stats.message_count} messages; {counts}")
    # each (topic, sequence number) once; what is missing is what the summary states as lost
    with open(out / "run.mcap", "rb") as f:
        seen: dict[str, list[int]] = {}
        for _, channel, message in make_reader(f).iter_messages():
            if not is_derived(channel.topic):  # each logger segment derives its own view
                seen.setdefault(channel.topic, []).append(message.sequence)
    assert all(len(set(v)) == len(v) for v in seen.values())
    # the producers' final counters are in the recording (from their drain queries if their
    # messages went by while no logger was up), and what they announced is recorded or stated lost
    assert summary["measurements"]["processed"] == total
    announced: dict[str, int] = {}
    for status_topic in ("/sim/status", "/fsw/status"):
        end = [r.message for r in read_messages(out / "run.mcap", topics=[status_topic])][-1]
        assert end.state == "end-of-run"
        announced.update({t: n for t, n in end.counts.items() if "/" in t})
    announced["fsw/status"] += 1  # the FSW counts the statuses before its end-of-run one
    for topic, n in announced.items():
        assert len(seen.get("/" + topic, [])) + restarts["gaps"].get(topic, 0) == n, topic
    assert set(restarts["gaps"]) <= set(announced)


def test_sigint_counts_what_was_delivered_but_not_processed(tmp_path):
    proc, out, run_id = _start(tmp_path, "sigint")
    _wait_for_checkpoint(out, 1000)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = _finish(proc, timeout_s=60)
    assert proc.returncode == 130, stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    last = [r.message for r in read_messages(out / "run.mcap", topics=["/fsw/status"])][-1]
    c = last.counts
    print(f"\nstopped: processed {c['processed']}, unprocessed {c['unprocessed']} (unread {c['unread']}, "
          f"pending {c['pending']}), taken {c['received']}")
    assert last.state == "error" and last.message == "stopped (signal)"
    # every measurement taken is processed, rejected or counted as unprocessed
    assert c["processed"] + c["rejected"] + c["unprocessed"] - c["unread"] == c["received"]
    assert summary["measurements"]["unprocessed"] == c["unprocessed"]
    assert summary["measurements"]["processed"] == c["processed"] >= 1000

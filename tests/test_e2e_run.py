"""End to end: real `navbank run` processes over real Zenoh on loopback, real MCAP read back."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader

from ground.mcap_io.reader import read_messages


def _navbank(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tools.cli", *args], capture_output=True, text=True, **kw)


@pytest.fixture(scope="module")
def short_run(tmp_path_factory, short_e2e_yaml):
    d = tmp_path_factory.mktemp("run")
    scen = d / "short.yaml"
    scen.write_text(short_e2e_yaml)
    out = d / "out"
    t0 = time.monotonic()
    proc = _navbank("run", "--scenario", str(scen), "--out", str(out), "--quiet", timeout=300)
    return proc, out, time.monotonic() - t0


def test_run_exits_cleanly_and_writes_its_files(short_run):
    proc, out, wall = short_run
    assert proc.returncode == 0, proc.stderr + proc.stdout
    for name in ("run.mcap", "summary.json", "config.yaml", "sim.log", "fsw.log", "ground.log"):
        assert (out / name).is_file(), name
    assert "position error RMS" in proc.stdout
    # the saved config is complete and re-runnable
    assert _navbank("validate", str(out / "config.yaml"), timeout=120).returncode == 0


def test_every_measurement_arrives_exactly_once(short_run):
    _, out, _ = short_run
    seqs = [r.message.seq for r in read_messages(out / "run.mcap", topics=["/sim/measurements"])]
    assert seqs == list(range(len(seqs)))
    assert len(seqs) > 2000
    summary = json.loads((out / "summary.json").read_text())
    m = summary["measurements"]
    assert m["published"] == len(seqs) == m["processed"]
    assert m["lost"] == 0 and m["rejected"] == 0


def test_expected_topics_with_valid_schemas(short_run):
    _, out, _ = short_run
    want = {"/sim/measurements", "/sim/truth", "/sim/faults", "/sim/status", "/fsw/weights/chi2",
            "/fsw/weights/magill", "/fsw/estimate/fused", "/fsw/estimate/combined", "/fsw/budget", "/fsw/status"}
    seen: dict[str, int] = {}
    with open(out / "run.mcap", "rb") as f:
        reader = make_reader(f)
        validators = {}
        for schema, channel, message in reader.iter_messages():
            if channel.message_encoding == "protobuf":  # Foxglove's well-known types: test_e2e_foxglove decodes them
                assert schema is not None and schema.name.startswith("foxglove.")
                assert message.log_time > 1.5e18
                continue
            assert channel.message_encoding == "json"
            assert schema is not None and schema.encoding == "jsonschema"
            if channel.topic not in validators:
                validators[channel.topic] = jsonschema.Draft202012Validator(json.loads(schema.data))
            n = seen.get(channel.topic, 0)
            if n < 50:  # validate a sample of every channel
                validators[channel.topic].validate(json.loads(message.data))
            seen[channel.topic] = n + 1
            assert message.log_time > 1.5e18 and message.publish_time > 1.5e18
    assert want <= set(seen), want - set(seen)


def test_summary_is_consistent_with_the_mcap(short_run):
    _, out, _ = short_run
    summary = json.loads((out / "summary.json").read_text())
    weights = [r.message for r in read_messages(out / "run.mcap", topics=["/fsw/weights/chi2"])]
    n = len(weights)
    assert summary["gating"]["chi2"]["updates"] == n
    for i, name in enumerate(weights[0].filters):
        mean = sum(w.weights[i] for w in weights) / n
        assert summary["gating"]["chi2"]["mean_weights"][name] == pytest.approx(mean, abs=1e-12)
    faults = [r.message for r in read_messages(out / "run.mcap", topics=["/sim/faults"])]
    assert summary["anomaly"]["onset_true"] == faults[0].t_s
    assert summary["fault"]["class"] == "optical-measurement"
    # a large optical bias: the chi2 network prefers the radio-only filter after onset
    after = summary["gating"]["chi2"]["mean_weights_after_onset"]
    assert after["radio"] > 0.8 and after["radio"] > after["optical"] and after["radio"] > after["fused"]
    budget = [r.message for r in read_messages(out / "run.mcap", topics=["/fsw/budget"])]
    assert summary["budget"]["overruns"] == max(b.overruns for b in budget)
    assert summary["budget"]["final_backlog"] == budget[-1].backlog == 0
    if summary["budget"]["mode"] == "cpu":
        # where the FSW's CPU went, stage by stage: its end-of-run status's counts per measurement
        status = [r.message for r in read_messages(out / "run.mcap", topics=["/fsw/status"])][-1]
        processed = status.counts["processed"]
        assert summary["budget"]["stage_cpu_us"] == pytest.approx(
            {k.removeprefix("stage_cpu_us_"): v / processed for k, v in status.counts.items()
             if k.startswith("stage_cpu_us_")})
    else:  # work units say nothing of the host's CPU
        assert summary["budget"]["stage_cpu_us"] is None


def test_the_logger_summarised_the_run_as_the_recording_does(short_run):
    """The summary comes from the logger, fed while it recorded (nothing read back after the run):
    it is the summary of the recording read back, to the last digit."""
    from ground.mcap_io.reader import summary as mcap_counts
    from ground.report.run_summary import reads_topic, summarize
    from tools.launcher import LOGGER_SUMMARY

    proc, out, _ = short_run
    assert "no summary written" not in (out / "ground.log").read_text()
    assert not (out / LOGGER_SUMMARY).exists()  # taken into summary.json
    written = json.loads((out / "summary.json").read_text())
    mcap = out / "run.mcap"
    messages = [(r.topic, r.message) for r in read_messages(mcap, topics=[t for t in mcap_counts(mcap) if reads_topic(t)],
                                                            sort_in_memory=True)]
    assert len(messages) > 2000
    back = summarize(messages, scenario=written["scenario"], seed=written["seed"], fault=written["fault"]["preset"],
                     t0=written["t0"], wall_time_s=written["wall_time_s"]).to_json()
    launcher_only = ("run_id", "status", "reason", "restarts", "files")
    assert {k: v for k, v in written.items() if k not in launcher_only} == json.loads(json.dumps(back))
    # the logger's counts of duplicates and gaps came with its summary: they are the recording's
    from tools.commands.run import _recorded_by_logger, _restarts_block

    assert written["restarts"] == _restarts_block([], written["t0"], _recorded_by_logger(mcap), [], [])


def _children(pid: int) -> list[int]:
    out = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        out.extend(int(t) for t in text)
    return out


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


@pytest.mark.slow
def test_killed_fsw_over_its_restarts_is_reported_and_the_run_stops(tmp_path, short_e2e_yaml):
    """With no restarts left (here none allowed) a killed FSW fails the run; the restarts
    themselves are drilled in test_restart_e2e.py."""
    scen = tmp_path / "long.yaml"
    scen.write_text(short_e2e_yaml.replace("span_days: 4.0", "span_days: 30.0"))
    proc = subprocess.Popen([sys.executable, "-m", "tools.cli", "run", "--scenario", str(scen), "--out", str(tmp_path / "o"),
                             "--quiet", "--max-restarts", "0", "--rate", f"{30 * 86400 / 40.0:g}"],  # still flying after 4 s
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        fsw_pid = None
        deadline = time.monotonic() + 60
        while fsw_pid is None and time.monotonic() < deadline:
            for c in _children(proc.pid):
                if " fsw " in _cmdline(c):
                    fsw_pid = c
            time.sleep(0.2)
        assert fsw_pid is not None, "fsw child not found"
        time.sleep(4.0)  # let it get going
        os.kill(fsw_pid, signal.SIGKILL)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1
    assert "fsw process exited with code -9" in err
    # the logger was stopped properly: its file is complete
    from ground.mcap_io.reader import is_complete

    assert is_complete(tmp_path / "o" / "run.mcap")


@pytest.mark.slow
@pytest.mark.parametrize("fault", [None, "none"])
def test_default_run_detects_the_optical_bias_and_a_nominal_run_raises_nothing(tmp_path, fault):
    """The README's main job: the built-in scenario's medium optical bias from day 20 is declared
    as an optical-measurement anomaly after its onset and nothing before; without a fault,
    nothing is declared."""
    args = ["run", "--out", str(tmp_path / "o"), "--quiet"] + ([] if fault is None else ["--fault", fault])
    proc = _navbank(*args, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["scenario"] == "insight-approach"
    assert s["anomaly"]["detector"]
    assert s["measurements"]["lost"] == 0 and s["measurements"]["processed"] == s["measurements"]["published"]
    assert s["budget"]["final_backlog"] == 0
    if fault is None:
        a = s["anomaly"]
        assert a["declared"] and not a["false_alarm"], a
        assert a["onset_true_day"] == pytest.approx(20.0, abs=1e-6)
        assert a["time_day"] > 20.0
        assert a["class"] == "optical-measurement"
        assert "ANOMALY declared" in proc.stdout and "diagnosis correct" in proc.stdout
    else:
        assert not s["anomaly"]["declared"], s["anomaly"]
        assert "no anomaly declared" in proc.stdout


def test_in_process_run_equals_the_multi_process_run_in_work_unit_mode(tmp_path, short_e2e_yaml):
    """Campaigns use the in-process runner; in deterministic budget mode it must give exactly the
    FSW outputs of the three processes over Zenoh."""
    import yaml

    from fsw.interface import codec, typed
    from tools.inprocess import run_in_process
    from tools.scenario import load_scenario, load_text_scenario

    # any calibration makes the detector run (this one is the built-in scenario's)
    cal = load_scenario("insight-approach").fsw.detector.calibration
    det = yaml.safe_dump({"detector": {"network": "chi2", "calibration": typed.encode(cal)}}, default_flow_style=True)
    text = short_e2e_yaml + "  budget: {mode: work-units}\n" + "  " + det.strip()[1:-1] + "\n"
    scen = tmp_path / "wu.yaml"
    scen.write_text(text)
    proc = _navbank("run", "--scenario", str(scen), "--out", str(tmp_path / "o"), "--quiet", timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    local = run_in_process(load_text_scenario(text))
    for topic in ("fsw/weights/chi2", "fsw/weights/magill", "fsw/anomaly", "fsw/estimate/fused", "fsw/budget"):
        recorded = [codec.to_json(r.message) for r in read_messages(tmp_path / "o" / "run.mcap", topics=["/" + topic])]
        mine = [codec.to_json(m) for m in local.topic(topic)]
        assert recorded and recorded == mine, topic
    assert local.summary.anomaly.declared


@pytest.mark.slow
def test_a_first_run_on_a_machine_compiles_its_kernels_and_completes(tmp_path, short_scenario):
    """The README's first command on a fresh machine: no compiled kernels cached yet, so the FSW
    compiles them before it opens its session (about 30 s of CPU on a 2-core Xeon), while the
    simulator, started with it, waits to reach it."""
    cache = tmp_path / "numba-cache"
    cache.mkdir()
    scen = tmp_path / "short.yaml"
    scen.write_text(short_scenario(span_days=0.5))
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "run", "--scenario", str(scen), "--out", str(out),
                           "--quiet"], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
    assert proc.returncode == 0, proc.stderr[-3000:] + proc.stdout[-3000:]
    assert list(cache.rglob("*.nbi")), "the kernels were compiled into the empty cache"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["measurements"]["processed"] == summary["measurements"]["published"] > 0


"""`navbank ground log` with real processes on 127.0.0.1: end-of-run, SIGKILL and SIGTERM."""

from __future__ import annotations

import json
import multiprocessing as mp
import signal
import subprocess
import sys
import time

import jsonschema
import pytest
from mcap.reader import make_reader

from fsw import transport as T
from fsw.interface import messages as m
from ground.logger import run_logger
from ground.mcap_io import is_complete, read_messages, recover, summary
from ground.report.run_summary import reads_topic, summarize
from child_results import collect_results

CTX = mp.get_context("spawn")
T0 = 1_700_000_000


def _stamp(i: int) -> m.Stamp:
    return m.Stamp(sec=T0 + i, nsec=0)


def _meas(i: int) -> m.Measurement:
    return m.Measurement(seq=i, t_s=6e8 + i, timestamp=_stamp(i), kind="range", source="DSS-63", value=(2e8 + i,), sigma=(0.001,))


def _end(run: str, source: str, pubs, **extra) -> m.RunStatus:
    return m.RunStatus(t_s=6e8, timestamp=_stamp(0), run_id=run, source=source, state="end-of-run",
                       counts=T.end_of_run_counts(pubs, **extra))


def sim_proc(cfg, run: str, n: int, out) -> None:
    with T.open_session(cfg) as s:
        T.wait_for_consumers(s, run, ["ground", "fsw"], timeout_s=20)
        meas, truth, status = (T.Publisher(s, run, t) for t in ("sim/measurements", "sim/truth", "sim/status"))
        status.put(m.RunStatus(t_s=6e8, timestamp=_stamp(0), run_id=run, source="sim", state="start"))
        for i in range(n):
            meas.put(_meas(i))
            if i % 100 == 0:
                truth.put(m.Truth(t_s=6e8 + i, timestamp=_stamp(i), position_km=(1.0, 2.0, 3.0), velocity_km_s=(0.1, 0.2, 0.3),
                                  clock_phase_s=0.0, clock_frequency=0.0, clock_drift_per_s=0.0))
        s.put(f"navbank/{run}/sim/debug", b'{"note":"not in the ICD"}')
        s.put(f"navbank/{run}/sim/measurements", b"{broken")
        end = _end(run, "sim", [meas, truth, status], published=n)
        status.put(end)
        out.put(("sim", T.drain(s, run, end, ["ground", "fsw"], timeout_s=30)))


def fsw_proc(cfg, run: str, n: int, out) -> None:
    """Publishes telemetry while the sim runs and ends after the sim's end of run, as the FSW does."""
    with T.open_session(cfg) as s, T.Subscriber(s, run, ("sim/status",), role="fsw") as sub:
        T.wait_for_consumers(s, run, ["ground"], timeout_s=20)
        weights, budget, status = (T.Publisher(s, run, t) for t in ("fsw/weights/chi2", "fsw/budget", "fsw/status"))
        deadline = time.monotonic() + 60
        while not sub.finished(["sim"]) and time.monotonic() < deadline:
            sub.recv(timeout=0.05)
        for i in range(n):
            weights.put(m.FilterWeights(t_s=6e8 + i, timestamp=_stamp(i), network="chi2", batch=i,
                                        filters=("radio", "optical", "fused"), weights=(0.9, 0.06, 0.04)))
            budget.put(m.BudgetReport(frame=i, t_s=6e8 + i, timestamp=_stamp(i), mode="work-units", used=3.0, budget=10.0,
                                      utilisation=0.3, processed=3, deferred=0, backlog=0, overruns=0))
        end = _end(run, "fsw", [weights, budget, status])
        status.put(end)
        acked = T.drain(s, run, end, ["ground"], timeout_s=30)
        assert sub.wait_acknowledged(["sim"], timeout_s=10)
        out.put(("fsw", acked))


def logger_proc(cfg, run: str, path: str, out, ready) -> None:
    from ground.report.summary_feed import SummaryFeed

    feed, closed = SummaryFeed(), []
    res = run_logger(run, path, cfg, ready_event=ready, attachments=[("scenario.yaml", b"name: test\n", "application/yaml")],
                     metadata={"scenario": "unit"}, print_fn=None, feed=feed,
                     on_closed=lambda r: closed.append((r.ended_by, is_complete(path))))
    fed = feed.summarize(scenario="unit", seed=0, fault=None, t0=6e8)
    out.put(("logger", (res, closed, len(feed), fed.to_json())))




def _join(procs, timeout=20):
    for p in procs:
        p.join(timeout)
        hung = p.is_alive()
        if hung:
            p.kill()
            p.join()
        assert not hung, f"{p.name} did not exit"


def test_logger_records_a_whole_run_and_ends_by_itself(tmp_path):
    run, path, n = "log-e2e", str(tmp_path / "run.mcap"), 3000
    cfgs = T.mesh_configs(["ground", "fsw", "sim"])
    out, ready = CTX.Queue(), CTX.Event()
    logger = CTX.Process(target=logger_proc, args=(cfgs["ground"], run, path, out, ready), name="logger")
    logger.start()
    assert ready.wait(30)
    sim = CTX.Process(target=sim_proc, args=(cfgs["sim"], run, n, out), name="sim")
    fsw = CTX.Process(target=fsw_proc, args=(cfgs["fsw"], run, 500, out), name="fsw")
    sim.start(), fsw.start()
    results = collect_results(out, 3, [sim, fsw, logger])
    _join([sim, fsw, logger])
    assert [p.exitcode for p in (sim, fsw, logger)] == [0, 0, 0]
    assert results["sim"] == {"ground": True, "fsw": True} and results["fsw"] == {"ground": True}
    res, closed, kept, fed = results["logger"]
    assert res.ended_by == "end-of-run" and set(res.finished) == {"sim", "fsw"}
    assert closed == [("end-of-run", True)]  # called once, the file finished
    # the summary fed as the messages came in is the summary of the file read back
    assert kept == 500 + 500 + 30 + 2 + 1  # budget, weights, truth, sim and fsw statuses (not the measurements)
    wanted = [t for t in summary(path) if reads_topic(t)]
    back = summarize([(r.topic, r.message) for r in read_messages(path, topics=wanted, sort_in_memory=True, strict=False)
                      if not isinstance(r.message, bytes)], scenario="unit", seed=0, fault=None, t0=6e8)
    assert fed == back.to_json()
    assert res.unknown == {"sim/debug": 1} and res.invalid == {"sim/measurements": 1} and res.gaps == {}

    assert is_complete(path)
    counts = summary(path)
    # the Foxglove view of the truth (a transform each) and of the status changes (test_e2e_foxglove checks them)
    assert counts.pop("/foxglove/transforms") == 30 and counts.pop("/foxglove/log") >= 2
    assert counts == {"/_invalid/sim/measurements": 1, "/fsw/budget": 500, "/fsw/status": 1, "/fsw/weights/chi2": 500,
                      "/sim/debug": 1, "/sim/measurements": n, "/sim/status": 2, "/sim/truth": 30}
    assert [x.message.seq for x in read_messages(path, "/sim/measurements")] == list(range(n))
    # Every message on a schema channel validates against the schema recorded in the file.
    validators = {}
    with open(path, "rb") as f:
        for schema, channel, msg in make_reader(f).iter_messages():
            if schema is None or channel.topic.startswith("/foxglove/"):
                continue
            assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
            v = validators.get(schema.id)
            if v is None:
                v = validators[schema.id] = jsonschema.Draft202012Validator(json.loads(schema.data))
            v.validate(json.loads(msg.data))
            assert msg.publish_time == json.loads(msg.data)["timestamp"]["sec"] * 10**9 + json.loads(msg.data)["timestamp"]["nsec"]
    assert len(validators) == 5  # Measurement, Truth, RunStatus (sim and fsw share it), FilterWeights, BudgetReport


def streaming_sim(cfg, run: str, rate_hz: float, duration_s: float, ready) -> None:
    """Publishes measurements at a steady rate; the logger may die under it at any moment."""
    with T.open_session(cfg) as s:
        T.wait_for_consumers(s, run, ["ground"], timeout_s=20)
        meas = T.Publisher(s, run, "sim/measurements")
        ready.set()
        t0 = time.monotonic()
        i = 0
        while time.monotonic() - t0 < duration_s:
            meas.put(_meas(i))
            i += 1
            time.sleep(max(0.0, t0 + i / rate_hz - time.monotonic()))


def _logger_cli(run: str, path: str, port: int) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "tools.cli", "ground", "log", "--run-id", run, "--out", path, "--listen", f"tcp/127.0.0.1:{port}", "--no-wait-end",
         "--flush-interval", "0.5", "--log-time", "receive"],  # receive time: the lag to the kill is measured
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["sigkill", "sigterm"])
def test_killed_logger_leaves_a_readable_file(tmp_path, sig):
    run, path = f"kill-{sig.name.lower()}", str(tmp_path / "run.mcap")
    cfgs = T.mesh_configs(["ground", "sim"])
    port = int(cfgs["ground"].listen[0].rsplit(":", 1)[1])
    logger = _logger_cli(run, path, port)
    ready = CTX.Event()
    sim = CTX.Process(target=streaming_sim, args=(cfgs["sim"], run, 2000.0, 5.0, ready), name="sim")
    sim.start()
    try:
        assert ready.wait(30), "publisher never found the logger"
        time.sleep(2.5)
        kill_ns = time.time_ns()
        logger.send_signal(sig)
        stdout, stderr = logger.communicate(timeout=20)
    finally:
        if logger.poll() is None:
            logger.kill()
        _join([sim], timeout=20)
    assert sim.exitcode == 0
    msgs = list(read_messages(path))
    seqs = [x.message.seq for x in msgs]
    assert seqs == list(range(len(seqs))) and len(seqs) > 1000  # an exact prefix of the stream
    lag_s = (kill_ns - msgs[-1].log_time_ns) * 1e-9
    print(f"\n{sig.name}: {len(seqs)} messages readable, last one {lag_s:.3f} s before the signal, complete={is_complete(path)}")
    if sig == signal.SIGKILL:
        assert logger.returncode == -signal.SIGKILL
        assert not is_complete(path)
        assert lag_s <= 1.0
        fixed = str(tmp_path / "fixed.mcap")
        res = recover(path, fixed)
        assert not res.complete and res.counts == {"/sim/measurements": len(seqs)}
        assert is_complete(fixed)
        with open(fixed, "rb") as f:
            assert sum(1 for _ in make_reader(f).iter_messages()) == len(seqs)
    else:
        assert logger.returncode == 0, stderr
        assert is_complete(path)
        assert lag_s <= 0.2  # everything up to the signal
        assert "/sim/measurements" in stdout and "signal" in stdout
        assert summary(path) == {"/sim/measurements": len(seqs)}

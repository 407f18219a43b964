"""Manual topology: sim and fsw only know the logger's endpoint; gossip links them directly."""

from __future__ import annotations

import multiprocessing as mp
import queue
import time

from fsw import transport as T
from fsw.interface import messages as m
from ground.foxglove.records import is_derived
from ground.logger import run_logger
from ground.mcap_io import summary

RUN = "gossip-test"
CTX = mp.get_context("spawn")


def _stamp() -> m.Stamp:
    return m.Stamp(sec=1_700_000_000, nsec=0)


def fsw(cfg, out) -> None:
    with T.open_session(cfg) as s, T.Subscriber(s, RUN, ("sim/measurements", "sim/status"), role="fsw") as sub:
        status = T.Publisher(s, RUN, "fsw/status")
        seqs = []
        deadline = time.monotonic() + 60
        while not (sub.finished(["sim"]) and sub.acknowledged.get("sim")) and time.monotonic() < deadline:
            got = sub.recv(timeout=0.1)
            if got is not None and isinstance(got.message, m.Measurement):
                seqs.append(got.message.seq)
        end = m.RunStatus(t_s=0.0, timestamp=_stamp(), run_id=RUN, source="fsw", state="end-of-run",
                          counts=T.end_of_run_counts([status], processed=len(seqs)))
        status.put(end)
        acked = T.drain(s, RUN, end, ["ground"], timeout_s=20)
        time.sleep(0.3)
        out.put(("fsw", (seqs, acked)))


def sim(cfg, out, n: int) -> None:
    with T.open_session(cfg) as s:
        T.wait_for_consumers(s, RUN, ["fsw", "ground"], timeout_s=30)
        meas, status = T.Publisher(s, RUN, "sim/measurements"), T.Publisher(s, RUN, "sim/status")
        for i in range(n):
            meas.put(m.Measurement(seq=i, t_s=float(i), timestamp=_stamp(), kind="range", source="DSS-14", value=(1.0,), sigma=(1.0,)))
        end = m.RunStatus(t_s=0.0, timestamp=_stamp(), run_id=RUN, source="sim", state="end-of-run",
                          counts=T.end_of_run_counts([meas, status]))
        status.put(end)
        out.put(("sim", T.drain(s, RUN, end, ["fsw", "ground"], timeout_s=30)))


def logger(cfg, path, out, ready) -> None:
    out.put(("ground", run_logger(RUN, path, cfg, ready_event=ready, print_fn=None)))


def test_processes_that_only_know_the_logger_reach_each_other(tmp_path):
    (port,) = T.free_tcp_ports(1)
    hub = T.TransportConfig(listen=(f"tcp/127.0.0.1:{port}",))
    spoke = T.TransportConfig(connect=(f"tcp/127.0.0.1:{port}",))  # listens on 127.0.0.1:0, gossip on
    path = str(tmp_path / "run.mcap")
    out, ready = CTX.Queue(), CTX.Event()
    procs = [CTX.Process(target=logger, args=(hub, path, out, ready))]
    procs[0].start()
    assert ready.wait(30)
    procs += [CTX.Process(target=fsw, args=(spoke, out)), CTX.Process(target=sim, args=(spoke, out, 2000))]
    for p in procs[1:]:
        p.start()
    results: dict = {}
    deadline = time.monotonic() + 90
    while len(results) < 3 and time.monotonic() < deadline:
        try:
            kind, value = out.get(timeout=0.5)
            results[kind] = value
        except queue.Empty:
            assert all(p.exitcode in (None, 0) for p in procs), "a process failed"
    assert len(results) == 3, f"timed out; got {sorted(results)}"
    for p in procs:
        p.join(20)
        alive = p.is_alive()
        if alive:
            p.kill()
            p.join()
        assert not alive and p.exitcode == 0
    seqs, fsw_acked = results["fsw"]
    assert seqs == list(range(2000))
    assert results["sim"] == {"fsw": True, "ground": True} and fsw_acked == {"ground": True}
    assert results["ground"].ended_by == "end-of-run"
    recorded = summary(path)
    assert {t: n for t, n in recorded.items() if not is_derived(t)} == {"/fsw/status": 1, "/sim/measurements": 2000,
                                                                        "/sim/status": 1}
    assert recorded["/foxglove/log"] == 2  # the logger's Foxglove view: one log line per end-of-run status

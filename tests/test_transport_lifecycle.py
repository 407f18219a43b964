"""ProcessLifecycle over real Zenoh on 127.0.0.1: clean ends, signals, unconfirmed consumers."""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import threading
import time

import pytest

from fsw import transport as T
from fsw.interface import messages as m, topics
from child_results import collect_results

RUN = "lifecycle"
CTX = mp.get_context("spawn")
T0 = 1_700_000_000


def _meas(i: int) -> m.Measurement:
    return m.Measurement(seq=i, t_s=6e8 + i, timestamp=m.Stamp(sec=T0 + i, nsec=0), kind="range", source="DSS-63",
                         value=(2e8 + i,), sigma=(0.001,))


def _end(source: str, counts: dict[str, int]) -> m.RunStatus:
    return m.RunStatus(t_s=6e8, timestamp=m.Stamp(sec=T0, nsec=0), run_id=RUN, source=source, state="end-of-run", counts=counts)


# -- two processes ------------------------------------------------------------------------------


def producer(cfg: T.TransportConfig, n: int, out) -> None:
    with T.ProcessLifecycle(RUN, cfg) as life:
        life.wait_for_consumers(["fsw"], timeout_s=20)
        credit = [T.CreditWindow(life.session, RUN, "fsw", topics.SIM_MEASUREMENTS, window=100, stall_timeout_s=30)]
        meas = life.publisher(topics.SIM_MEASUREMENTS, credit=credit)
        for i in range(n):
            meas.put(_meas(i))
        done = life.end_of_stream(topics.SIM_STATUS, _end("sim", T.end_of_run_counts([meas])), ["fsw"], timeout_s=30)
        out.put(("sim", done))


def consumer(cfg: T.TransportConfig, out) -> None:
    with T.ProcessLifecycle(RUN, cfg) as life:
        sub = life.subscriber((topics.SIM_MEASUREMENTS, topics.SIM_STATUS), role="fsw", capacity=1000)
        seqs = []
        deadline = time.monotonic() + 60
        while not sub.finished(["sim"]) and time.monotonic() < deadline:
            got = sub.recv(timeout=0.05)
            if got is not None and got.topic == topics.SIM_MEASUREMENTS:
                seqs.append(got.message.seq)
        acknowledged = life.wait_acknowledged(sub, ["sim"], timeout_s=30)
        out.put(("fsw", (seqs, acknowledged, dict(sub.gaps))))


def _join(procs, timeout_s: float = 20.0) -> None:
    for p in procs:
        p.join(timeout_s)
        hung = p.is_alive()
        if hung:
            p.kill()
            p.join()
        assert not hung, f"{p.name} did not exit (hang at exit)"




def test_producer_and_consumer_end_cleanly_with_every_message_confirmed():
    n = 2000
    cfgs = T.mesh_configs(["fsw", "sim"])
    out = CTX.Queue()
    cons = CTX.Process(target=consumer, args=(cfgs["fsw"], out), name="consumer")
    prod = CTX.Process(target=producer, args=(cfgs["sim"], n, out), name="producer")
    cons.start(), prod.start()
    results = collect_results(out, 2, [cons, prod])
    _join([cons, prod])
    assert [p.exitcode for p in (cons, prod)] == [0, 0]
    assert results["sim"] == {"fsw": True}
    seqs, acknowledged, gaps = results["fsw"]
    assert seqs == list(range(n)) and acknowledged and gaps == {}


def signalled_process(ready, out) -> None:
    """Waits inside the lifecycle, with a progress queryable (a Zenoh callback) declared, until stopped."""

    def marker(signum, frame):  # the handler the lifecycle must put back
        out.put(("marker", signum))

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, marker)
    with T.ProcessLifecycle(RUN, T.TransportConfig()) as life:
        life.subscriber(("**",), role="ground")
        life.publisher(topics.FSW_STATUS)
        life.command_server(lambda cmd: m.TelecommandReply(id=cmd.id, ok=True), threaded=True)
        ready.set()
        deadline = time.monotonic() + 30
        while not life.should_stop() and time.monotonic() < deadline:
            time.sleep(0.01)
        reason = life.stop_reason()
    restored = all(signal.getsignal(s) is marker for s in (signal.SIGINT, signal.SIGTERM))
    out.put(("child", (reason, restored)))


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["sigterm", "sigint"])
def test_a_signal_stops_the_process_restores_handlers_and_closes_without_hanging(sig):
    ready, out = CTX.Event(), CTX.Queue()
    proc = CTX.Process(target=signalled_process, args=(ready, out), name="signalled")
    proc.start()
    try:
        assert ready.wait(30), "the process never entered its lifecycle"
        t0 = time.monotonic()
        os.kill(proc.pid, sig)
        results = collect_results(out, 1, [proc], timeout_s=20)
        _join([proc])
    finally:
        if proc.is_alive():
            proc.kill()
            proc.join()
    assert proc.exitcode == 0
    assert results["child"] == ("signal", True)
    assert time.monotonic() - t0 < 10
    assert "marker" not in results  # the signal went to the lifecycle, not to the old handler


# -- one process, two sessions ------------------------------------------------------------------


@pytest.fixture()
def mesh():
    return T.mesh_configs(["ground", "fsw", "sim"])


def test_the_drain_names_the_consumer_that_did_not_confirm(mesh):
    with T.ProcessLifecycle(RUN, mesh["ground"], handle_signals=False) as ground, \
            T.ProcessLifecycle(RUN, mesh["fsw"], handle_signals=False) as fsw, \
            T.ProcessLifecycle(RUN, mesh["sim"], handle_signals=False) as sim:
        ground.subscriber(("sim/**",), role="ground")  # never takes anything: cannot confirm
        fsw.subscriber((topics.SIM_FAULTS,), role="fsw")  # announced topics are not its own: confirms at once
        sim.wait_for_consumers(["ground", "fsw"], timeout_s=20)
        meas = sim.publisher(topics.SIM_MEASUREMENTS)
        for i in range(5):
            meas.put(_meas(i))
        end = _end("sim", T.end_of_run_counts([meas]))
        t0 = time.monotonic()
        with pytest.raises(T.TransportError, match=r"confirmation from ground$"):
            sim.end_of_stream(topics.SIM_STATUS, end, ["ground", "fsw"], timeout_s=1.0)
        assert time.monotonic() - t0 < 10
        assert sim.confirm_end(end, ["ground", "fsw"], timeout_s=0.5, require_all=False) == {"ground": False, "fsw": True}


def test_the_consumer_serves_commands_while_it_waits_for_the_producer():
    cfgs = T.mesh_configs(["fsw", "sim"])
    out: dict = {}
    up, waiting = threading.Event(), threading.Event()

    def fsw_main() -> None:
        with T.ProcessLifecycle(RUN, cfgs["fsw"], handle_signals=False) as life:
            sub = life.subscriber((topics.SIM_MEASUREMENTS, topics.SIM_STATUS), role="fsw")
            life.command_server(lambda cmd: m.TelecommandReply(id=cmd.id, ok=True, detail={"who": "fsw"}), threaded=False)
            up.set()
            deadline = time.monotonic() + 30
            while not sub.finished(["sim"]) and time.monotonic() < deadline:
                sub.recv(timeout=0.05)
                life.poll_commands()
            waiting.set()
            out["acknowledged"] = life.wait_acknowledged(sub, ["sim"], timeout_s=30)

    thread = threading.Thread(target=fsw_main)
    thread.start()
    try:
        assert up.wait(30), "the consumer never came up"
        with T.ProcessLifecycle(RUN, cfgs["sim"], handle_signals=False) as sim:
            sim.wait_for_consumers(["fsw"], timeout_s=20)
            meas = sim.publisher(topics.SIM_MEASUREMENTS)
            for i in range(50):
                meas.put(_meas(i))
            end = _end("sim", T.end_of_run_counts([meas]))
            sim.announce_end(topics.SIM_STATUS, end)
            # the consumer has everything but was not told so yet: it waits, serving commands
            assert waiting.wait(30), "the consumer never finished the stream"
            reply = T.send_command(sim.session, RUN, m.Telecommand(id="c1", command="status"), timeout_s=5.0)
            assert reply.ok and reply.detail == {"who": "fsw"}
            assert sim.confirm_end(end, ["fsw"], timeout_s=10) == {"fsw": True}
    finally:
        thread.join(40)
    assert not thread.is_alive() and out == {"acknowledged": True}


def test_handlers_restored_and_endpoints_closed_when_the_body_raises():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with pytest.raises(ValueError, match="body"):
        with T.ProcessLifecycle(RUN, T.TransportConfig()) as life:
            assert all(signal.getsignal(s) is not before[s] for s in before)
            sub = life.subscriber(("**",), role="ground")
            pub = life.publisher(topics.SIM_STATUS)
            assert life.publisher(topics.SIM_STATUS) is pub and list(life.publishers) == [topics.SIM_STATUS]
            raise ValueError("body")
    assert {s: signal.getsignal(s) for s in before} == before
    assert sub._queryable is None and sub._subs == []  # undeclared: nothing keeps the process alive
    with pytest.raises(RuntimeError, match="only inside"):
        life.session


def test_stop_event_and_signals_off_the_main_thread():
    stop = threading.Event()
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    seen: dict = {}

    def body() -> None:
        with T.ProcessLifecycle(RUN, T.TransportConfig(), stop_event=stop) as life:
            seen["handlers"] = {s: signal.getsignal(s) for s in before}  # untouched off the main thread
            seen["before"] = life.stop_reason()
            stop.set()
            seen["after"] = (life.stop_reason(), life.should_stop(), life.signalled)

    thread = threading.Thread(target=body)
    thread.start()
    thread.join(30)
    assert not thread.is_alive()
    assert seen == {"handlers": before, "before": None, "after": ("stop", True, False)}


def test_a_failed_open_leaves_the_handlers_as_they_were():
    (port,) = T.free_tcp_ports(1)
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with pytest.raises(T.TransportError, match="cannot open"):
        with T.ProcessLifecycle(RUN, T.TransportConfig(connect=(f"tcp/127.0.0.1:{port}",), connect_timeout_s=0.5)):
            pass
    assert {s: signal.getsignal(s) for s in before} == before

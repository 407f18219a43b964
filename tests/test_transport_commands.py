"""Telecommand round trips over real Zenoh between two processes, including malformed payloads."""

from __future__ import annotations

import multiprocessing as mp
import os
import random

import pytest

from fsw import transport as T
from fsw.interface import messages as m

RUN = "cmd-test"
CTX = mp.get_context("spawn")


def fsw_server(cfg: T.TransportConfig, stop, ready, threaded: bool) -> None:
    """A minimal command handler: 'status' reports the server's own counters, 'disable-filter' of an
    unknown filter is refused, anything else is accepted; 'set-param' with param 'explode' raises."""
    with T.open_session(cfg) as session:
        server: T.CommandServer | None = None

        def handle(cmd: m.Telecommand) -> m.TelecommandReply:
            if cmd.command == "status":
                return m.TelecommandReply(id=cmd.id, ok=True, status=server.status(), detail={"pid": str(os.getpid())})
            if cmd.command == "set-param" and cmd.param == "explode":
                raise RuntimeError("boom")
            if cmd.command == "disable-filter" and cmd.filter not in ("radio", "optical", "fused"):
                return m.TelecommandReply(id=cmd.id, ok=False, error=f"unknown filter {cmd.filter!r}")
            return m.TelecommandReply(id=cmd.id, ok=True)

        with T.declare_command_server(session, RUN, handle, threaded=threaded) as server:
            ready.set()
            while not stop.wait(0.01 if not threaded else 0.2):
                server.poll()


@pytest.fixture(params=[True, False], ids=["threaded", "polled"])
def server(request):
    cfgs = T.mesh_configs(["fsw", "ground"])
    stop, ready = CTX.Event(), CTX.Event()
    proc = CTX.Process(target=fsw_server, args=(cfgs["fsw"], stop, ready, request.param))
    proc.start()
    try:
        assert ready.wait(30), "command server did not start"
        with T.open_session(cfgs["ground"]) as session:
            yield session
    finally:
        stop.set()
        proc.join(timeout=15)
        hung = proc.is_alive()
        if hung:
            proc.kill()
            proc.join()
        assert not hung, "command server did not exit (hang at exit)"
        assert proc.exitcode == 0


def _status(session) -> dict[str, float]:
    reply = T.send_command(session, RUN, m.Telecommand(id="st", command="status"), timeout_s=5)
    assert reply.ok and reply.id == "st"
    return reply.status


def test_round_trip_and_malformed_payloads(server):
    session = server
    reply = T.send_command(session, RUN, m.Telecommand(id="c1", command="reset-gating", network="chi2"), timeout_s=5)
    assert reply == m.TelecommandReply(id="c1", ok=True)
    refused = T.send_command(session, RUN, m.Telecommand(id="c2", command="disable-filter", filter="nope"), timeout_s=5)
    assert not refused.ok and "nope" in refused.error

    rng = random.Random(7)
    bad = [
        bytes(rng.getrandbits(8) for _ in range(64)),  # random bytes
        b"",  # empty
        b'{"id":"n1","command":"set-param","network":"chi2","param":"sigma_w","value":NaN}',  # NaN
        b'{"id":"n2","command":"set-param","network":"chi2","param":"sigma_w","value":1e999}',  # inf
        b'{"id":"n3","command":"launch-missiles"}',  # unknown enum value
        b'{"id":"n4","command":"enable-filter"}',  # missing the filter
        b'{"id":"n5","command":"status","extra":1}',  # unknown key
        b"[" * 100_000,  # deep nesting
    ]
    for i, payload in enumerate(bad):
        reply = T.send_command_payload(session, RUN, payload, timeout_s=5)
        assert not reply.ok and reply.error.startswith("malformed"), (i, reply)
    assert T.send_command_payload(session, RUN, b'{"id":"n4","command":"enable-filter"}', timeout_s=5).id == "n4"
    wrong_schema = T.send_command_payload(session, RUN, b'{"id":"w","command":"status"}', schema="navbank.Measurement/v1", timeout_s=5)
    assert not wrong_schema.ok and "schema" in wrong_schema.error and wrong_schema.id == "w"
    crash = T.send_command(session, RUN, m.Telecommand(id="x", command="set-param", network="chi2", param="explode", value=1.0), timeout_s=5)
    assert not crash.ok and "boom" in crash.error

    # The server kept running and counted everything.
    status = _status(session)
    assert status["malformed"] == len(bad) + 2
    assert status["handler_errors"] == 1
    assert status["served"] == 2  # c1 and c2 (the status command counts after its reply is built)


def test_no_server_is_an_error_not_a_hang():
    with T.open_session(T.TransportConfig()) as session:
        with pytest.raises(T.TransportError, match="no FSW"):
            T.send_command(session, "nobody-here", m.Telecommand(id="a", command="status"), timeout_s=0.5)

"""Authenticated transport over real Zenoh on 127.0.0.1: mutual TLS, the access-control list by role,
and the HMAC refusals of telecommands, statuses and drain queries (counted, changing nothing)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
import zenoh

from fsw import transport as T
from fsw.interface import auth, codec, topics
from fsw.interface.messages import RunStatus, Stamp, Telecommand, TelecommandReply
from fsw.transport.credentials import load_credentials
from tools.credentials import make_credentials

RUN = "auth-test"


@pytest.fixture(scope="module")
def creds(tmp_path_factory) -> tuple[Path, Path]:
    base = tmp_path_factory.mktemp("creds")
    return make_credentials(base / "run"), make_credentials(base / "other")


def _cfg(creds_dir: Path, role: str, connect: str) -> T.TransportConfig:
    return T.TransportConfig(listen=(), connect=(connect,), credentials=load_credentials(creds_dir, role),
                             connect_timeout_s=2.0)


@pytest.fixture()
def fsw_peer(creds):
    """A peer holding the fsw certificate and the run's ACL: it records what reaches it and
    answers telecommands."""
    run_dir, _ = creds
    port = T.free_tcp_ports(1)[0]
    ep = f"tls/127.0.0.1:{port}"
    cfg = T.TransportConfig(listen=(ep,), credentials=load_credentials(run_dir, "fsw"))
    with T.open_session(cfg) as s:
        sub = s.declare_subscriber(f"navbank/{RUN}/**", zenoh.handlers.FifoChannel(1000))
        served: list[str] = []

        def answer(q):
            served.append(str(q.key_expr))
            q.reply(q.key_expr, b"served")

        q = s.declare_queryable(topics.key(RUN, topics.FSW_COMMAND), answer)
        try:
            yield ep, sub, served
        finally:
            q.undeclare()
            sub.undeclare()


def _until_matched(*entities, timeout_s: float = 5.0) -> None:
    """Wait until each publisher or querier sees the peer's subscriber or queryable: only then does
    a put or query that gets nowhere say something about the access-control list."""
    deadline = time.monotonic() + timeout_s
    while not all(e.matching_status.matching for e in entities):
        assert time.monotonic() < deadline, "the peer's declarations never arrived"
        time.sleep(0.01)


def _received(sub, wait_s: float = 0.5) -> list[str]:
    time.sleep(wait_s)
    out = []
    while (x := sub.try_recv()) is not None:
        out.append(str(x.key_expr))
    return out


def test_the_access_control_list_lets_each_role_do_only_its_own_job(creds, fsw_peer):
    run_dir, _ = creds
    ep, sub, served = fsw_peer
    status_key = topics.key(RUN, topics.SIM_STATUS)
    cmd_key = topics.key(RUN, topics.FSW_COMMAND)
    outcome = {}
    for role in ("sim", "ground", "operator", "fsw"):
        with T.open_session(_cfg(run_dir, role, ep)) as s:
            pub, querier = s.declare_publisher(status_key), s.declare_querier(cmd_key, timeout=1.0)
            _until_matched(pub, querier)
            pub.put(f"from {role}".encode())
            replies = [r.ok.payload.to_bytes() for r in querier.get() if r.ok is not None]
            outcome[role] = (tuple(_received(sub)), tuple(replies))
            querier.undeclare()
            pub.undeclare()
            time.sleep(0.1)
    # only the simulator may put on sim/**, only the operator may command; every other attempt is
    # dropped by the receiving peer without a word
    assert outcome == {
        "sim": ((status_key,), ()),
        "ground": ((), ()),
        "operator": ((), (b"served",)),
        "fsw": ((), ()),
    }
    assert served == [cmd_key]


def test_peers_without_a_certificate_of_the_run_cannot_link(creds, fsw_peer, tmp_path):
    run_dir, other_dir = creds
    ep, sub, _ = fsw_peer
    port = ep.rsplit(":", 1)[1]
    no_client_cert = tmp_path / "tls-no-cert.json5"
    no_client_cert.write_text(f'{{transport: {{link: {{tls: {{root_ca_certificate: "{run_dir / "ca.pem"}"}}}}}}}}')
    attempts = {
        "plain tcp": T.TransportConfig(listen=(), connect=(f"tcp/127.0.0.1:{port}",), connect_timeout_s=1.0),
        "tls, no client certificate": T.TransportConfig(listen=(), connect=(ep,), connect_timeout_s=1.0,
                                                         config_file=str(no_client_cert)),
        "certificate of another run's CA": _cfg(other_dir, "sim", ep),
    }
    for label, cfg in attempts.items():
        with pytest.raises(T.TransportError):
            with T.open_session(cfg) as s:
                s.put(topics.key(RUN, topics.SIM_STATUS), b"forged")
        # the peer was alive all along: a run certificate still gets through right after
        with T.open_session(_cfg(run_dir, "sim", ep)) as s:
            pub = s.declare_publisher(topics.key(RUN, topics.SIM_STATUS))
            _until_matched(pub)
            pub.put(label.encode())
            assert _received(sub, 0.3) == [topics.key(RUN, topics.SIM_STATUS)], label
            pub.undeclare()


# -- the application layer (plain links: what it refuses does not depend on the transport) ----------
@pytest.fixture()
def pair():
    cfgs = T.mesh_configs(["fsw", "ground"])
    with T.open_session(cfgs["fsw"]) as a, T.open_session(cfgs["ground"]) as b:
        yield a, b


KEY = bytes(range(32))


def test_unsigned_forged_and_replayed_telecommands_are_refused_and_reported(pair):
    fsw_session, ground = pair
    handled: list[Telecommand] = []
    refused: list[tuple[str, str]] = []

    def handle(cmd: Telecommand) -> TelecommandReply:
        handled.append(cmd)
        return TelecommandReply(id=cmd.id, ok=True)

    good, bad = auth.MessageAuthenticator(KEY), auth.MessageAuthenticator(bytes(32))
    with T.CommandServer(fsw_session, RUN, handle, authenticator=good,
                         on_refused=lambda cmd, payload, reply, why: refused.append((cmd.id, why))) as server:
        deadline = time.monotonic() + 10
        while True:  # until the queryable's declaration has reached the other session
            try:
                assert T.send_command(ground, RUN, Telecommand(id="probe", command="status"), timeout_s=0.5,
                                      authenticator=good).ok
                break
            except T.TransportError:
                assert time.monotonic() < deadline, "the command server never answered"
        handled.clear()
        cmd = Telecommand(id="d1", command="disable-filter", filter="radio")
        r_none = T.send_command(ground, RUN, cmd)
        r_bad = T.send_command(ground, RUN, cmd, authenticator=bad)
        signed = good.sign(cmd)
        r_ok = T.send_command_payload(ground, RUN, codec.to_json(signed))
        r_again = T.send_command_payload(ground, RUN, codec.to_json(signed))
        r_fresh = T.send_command(ground, RUN, cmd, authenticator=good)
        status = server.status()
    assert (r_none.ok, r_none.error) == (False, f"refused: {auth.MISSING}")
    assert (r_bad.ok, r_bad.error) == (False, f"refused: {auth.BAD}")
    assert r_ok.ok and r_fresh.ok
    assert (r_again.ok, r_again.error) == (False, f"refused: {auth.REPLAYED}")
    assert handled == [signed, handled[1]] and len(handled) == 2  # only the two valid ones reached the handler
    assert refused == [("d1", auth.MISSING), ("d1", auth.BAD), ("d1", auth.REPLAYED)]
    assert status == {"served": 3, "malformed": 0, "refused": 3, "handler_errors": 0}  # with the probe


def _end(counts: dict[str, int]) -> RunStatus:
    return RunStatus(t_s=1.0, timestamp=Stamp(sec=1, nsec=0), run_id=RUN, source="sim", state="end-of-run", counts=counts)


def test_a_forged_end_of_run_status_or_drain_ends_nothing(pair):
    producer, consumer = pair
    good, bad = auth.MessageAuthenticator(KEY), auth.MessageAuthenticator(bytes(32))
    # dedupe as the logger does: the forged status (publisher number 0) must not make the real one
    # (number 0 too) look like a repeat
    with T.Subscriber(consumer, RUN, ("sim/**",), decode=False, role="ground", authenticator=good, dedupe=True) as sub, \
            T.Publisher(producer, RUN, topics.SIM_STATUS, authenticator=bad) as forger, \
            T.Publisher(producer, RUN, topics.SIM_STATUS, authenticator=good) as real:
        T.wait_for_consumers(producer, RUN, ["ground"], timeout_s=10)
        forger.put(_end({}))
        got = sub.recv(timeout=5)
        assert got is not None and got.refused == auth.BAD
        assert not sub.finished(["sim"]) and sub.refused == {topics.SIM_STATUS: 1}
        # an unsigned drain query and a drain signed with the wrong key are answered "not complete"
        for status in (_end({}), bad.sign(_end({}))):
            reply = T.query_progress(producer, RUN, "ground", status)
            assert reply is not None and reply.counts.get(T.COMPLETE) == 0
        assert not sub.acknowledged and sub.refused["ground/progress"] == 2
        real.put(_end({}))
        got = sub.recv(timeout=5)
        assert got is not None and got.refused == "" and sub.finished(["sim"])
        reply = T.query_progress(producer, RUN, "ground", good.sign(_end({})))
        assert reply is not None and reply.counts.get(T.COMPLETE) == 1 and sub.acknowledged == {"sim": True}


def test_credentials_configure_tls_and_the_acl_and_refuse_plain_endpoints(creds):
    run_dir, _ = creds
    c = load_credentials(run_dir, "sim")
    zc = T.zenoh_config(T.TransportConfig(listen=("tls/127.0.0.1:0",), credentials=c))
    tls = json.loads(zc.get_json("transport/link/tls"))
    assert tls["enable_mtls"] and tls["root_ca_certificate"] == str(run_dir / "ca.pem")
    assert tls["connect_certificate"] == tls["listen_certificate"] == str(run_dir / "sim.pem")
    acl = json.loads(zc.get_json("access_control"))
    assert acl["enabled"] and acl["default_permission"] == "deny"
    with pytest.raises(ValueError, match="tls/"):
        T.TransportConfig(credentials=c)  # the default listener is plain TCP
    with pytest.raises(ValueError, match="tls/"):
        T.TransportConfig(listen=("tls/127.0.0.1:0",), connect=("tcp/127.0.0.1:7447",), credentials=c)


def test_processes_with_credentials_announce_and_join_only_tls_endpoints(creds, tmp_path, monkeypatch):
    import argparse
    import os

    from tools import rendezvous

    run_dir, _ = creds
    xdg = tmp_path / "xdg"
    xdg.mkdir(mode=0o700)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(xdg))
    base = dict(listen=None, connect=None, client=False, zenoh_config=None, no_gossip=False, connect_timeout=10.0,
                role=None)
    plain = argparse.Namespace(**base, credentials=None)
    secure = argparse.Namespace(**base, credentials=str(run_dir))
    with rendezvous.joined(plain, "mixed", "ground") as p:
        assert p.listen[0].startswith("tcp/") and p.credentials is None
        # the announcing processes would be other processes: pretend the file is another pid's
        (f,) = (xdg / "navbank" / "mixed").glob("ground-*.json")
        entry = json.loads(f.read_text())
        f.write_text(json.dumps({**entry, "pid": os.getppid()}))
        with rendezvous.joined(secure, "mixed", "fsw", announce=False) as s:
            assert s.listen[0].startswith("tls/") and s.credentials is not None and s.credentials.role == "fsw"
            assert s.connect == ()  # the plain TCP peer is not joined
        with rendezvous.joined(plain, "mixed", "sim", announce=False) as q:
            assert q.connect == (p.listen[0],)
        with rendezvous.joined(secure, "mixed", "fsw") as s:
            (f,) = (xdg / "navbank" / "mixed").glob("fsw-*.json")
            f.write_text(json.dumps({**json.loads(f.read_text()), "pid": os.getppid()}))
            with rendezvous.joined(secure, "mixed", "sim", announce=False) as t:
                assert t.connect == (s.listen[0],)  # the TLS peer, and only it


def test_only_the_fsw_may_answer_under_its_keys(creds):
    """A peer of the run in another role cannot serve the FSW's progress (or command) queries in
    its place: its queryable and replies are dropped; the FSW's own certificate is answered."""
    run_dir, _ = creds
    port = T.free_tcp_ports(1)[0]
    ep = f"tls/127.0.0.1:{port}"
    key = topics.key(RUN, "fsw/progress")
    answers = {}
    with T.open_session(T.TransportConfig(listen=(ep,), credentials=load_credentials(run_dir, "sim"))) as asker:
        querier = asker.declare_querier(key, timeout=1.0)
        for role in ("ground", "operator", "fsw"):
            with T.open_session(_cfg(run_dir, role, ep)) as s:
                q = s.declare_queryable(key, lambda query: query.reply(query.key_expr, b"complete"))
                deadline = time.monotonic() + 2.0
                while not querier.matching_status.matching and time.monotonic() < deadline:
                    time.sleep(0.01)
                answers[role] = (querier.matching_status.matching,
                                 [r.ok.payload.to_bytes() for r in querier.get() if r.ok is not None])
                q.undeclare()
                time.sleep(0.1)
        querier.undeclare()
    assert answers == {"ground": (False, []), "operator": (False, []), "fsw": (True, [b"complete"])}

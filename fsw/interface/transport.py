"""Zenoh transport of the ICD: sessions, typed publishers/subscribers, flow control, telecommands.

Every navbank process talks through this module, so the measured Zenoh pitfalls
(the design notes NOTES-zenoh-mcap.md) are handled once, here:

* **Loopback by default.** Sessions are peers, multicast scouting off, listening on
  ``tcp/127.0.0.1:0``; nothing binds to another interface unless asked (``--listen``).
* **Failed connects are errors.** Connect endpoints are opened with ``connect/timeout_ms`` and
  ``connect/exit_on_failure``, so an unreachable peer raises :class:`TransportError` instead of
  a silent session with zero peers. Zenoh then requires *every* connect endpoint to answer.
* **Topology.** Peers do not forward data for other peers, so every pair of processes needs a
  direct link. Gossip is on by default: processes that only know one rendezvous endpoint
  (``--connect`` to the logger, say) learn each other's listeners from it and link directly.
  ``navbank run`` knows all processes and uses :func:`mesh_configs`: a fixed free port per
  process, each connecting to the ones started before it, so the mesh does not depend on gossip.
* **No loss on a live link.** Publishers are RELIABLE with congestion control BLOCK and stamp a
  per-publisher sequence number in the attachment; subscribers count gaps. Subscribers use
  bounded FIFO channels (no Python callbacks on the data path, so no exit hang).
* **No loss when a consumer stalls** (BLOCK gives up after ~5 s): :class:`CreditWindow` keeps a
  producer at most ``window`` messages ahead of what a consumer has *taken* from its FIFO, as the
  consumer reports through its progress queryable.
* **No loss at close** (closing right after the last put loses the messages in flight): the
  end-of-stream handshake below.

Progress queryable and end-of-stream handshake
----------------------------------------------
A consumer's :class:`Subscriber` created with ``role=...`` answers queries on
``navbank/<run>/<role>/progress`` with a :class:`~fsw.interface.messages.RunStatus` whose
``counts`` hold, per topic, the messages taken from its channels so far.

A producer ends a run by publishing its end-of-run ``RunStatus`` whose ``counts`` carry, for every
topic it published, the number of messages (keys containing ``/`` are topic counts; other keys are
free-form counters). It then calls :func:`drain`, which sends that same status as the payload of a
progress query to each consumer until each one replies ``counts["complete"] == 1`` — i.e. it has
taken at least the announced number of messages on every announced topic it subscribes to.
Only then may the producer close its session. The consumer remembers which producers it has
acknowledged (:attr:`Subscriber.acknowledged`), so it can itself close once every producer it waits
for has both ended (:meth:`Subscriber.finished`) and been told so; a short linger after the last
reply lets that reply leave before the session closes.

Telecommands
------------
:func:`declare_command_server` serves ``navbank/<run>/fsw/cmd``: a strict ICD decode of the query
payload, the handler's :class:`TelecommandReply` back, a ``TelecommandReply(ok=False)`` for a
malformed payload (counted), never an exception, and the Query dropped after every reply.
:func:`send_command` is the ground side.
"""

from __future__ import annotations

import argparse
import json
import math
import socket
import struct
import threading
import time
import typing
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

import zenoh

from fsw.interface import codec, topics
from fsw.interface.messages import RunStatus, Stamp, Telecommand, TelecommandReply
from fsw.interface.typed import spec

#: Roles that may serve a progress queryable (the ``source`` values of RunStatus).
ROLES: tuple[str, ...] = typing.get_args(typing.get_type_hints(RunStatus)["source"])
PROGRESS = "progress"  # navbank/<run>/<role>/progress: consumer progress queryable
COMPLETE = "complete"  # counts key of a progress reply: 1 when the producer's stream is complete
_SEQ = struct.Struct("<Q")


class TransportError(RuntimeError):
    """A Zenoh session, link, query or flow-control wait failed."""


@dataclass(frozen=True, slots=True)
class TransportConfig:
    """How a navbank process joins the Zenoh network.

    Fields here always override the same keys of ``config_file``; the file supplies everything
    else (TLS, user/password auth, access control, namespace, ...).
    """

    mode: Literal["peer", "client"] = spec("peer", doc="Zenoh mode: 'peer' (embedded, no router needed) or 'client' (through a router)")
    listen: tuple[str, ...] = spec(
        ("tcp/127.0.0.1:0",), doc="endpoints to listen on (peer mode); port 0 picks a free port; loopback unless told otherwise"
    )
    connect: tuple[str, ...] = spec((), doc="endpoints to connect to; every one must answer within connect_timeout_s")
    multicast_scouting: bool = spec(False, doc="discover peers by UDP multicast (off: loopback simulators must not leak onto the LAN)")
    gossip: bool = spec(True, doc="learn other peers' listeners through connected peers and link to them directly")
    config_file: str | None = spec(None, doc="Zenoh JSON5 configuration file used as the base configuration")
    connect_timeout_s: float = spec(10.0, doc="time allowed for every connect endpoint to answer", unit="s", gt=0.0)

    def __post_init__(self) -> None:
        for ep in (*self.listen, *self.connect):
            if "/" not in ep or not ep.split("/", 1)[1]:
                raise ValueError(f"endpoint {ep!r}: expected <protocol>/<address>, e.g. tcp/127.0.0.1:7447")
        if self.mode == "client" and not self.connect:
            raise ValueError("client mode needs at least one connect endpoint (a router)")


def zenoh_config(cfg: TransportConfig) -> zenoh.Config:
    """The zenoh.Config for ``cfg`` (see :class:`TransportConfig` for precedence)."""
    try:
        zc = zenoh.Config.from_file(cfg.config_file) if cfg.config_file else zenoh.Config()
    except zenoh.ZError as exc:
        raise TransportError(f"zenoh config file {cfg.config_file!r}: {exc}") from None

    def put(path: str, value: Any) -> None:
        try:
            zc.insert_json5(path, json.dumps(value))
        except zenoh.ZError as exc:
            raise TransportError(f"zenoh config {path} = {value!r}: {exc}") from None

    put("mode", cfg.mode)
    put("scouting/multicast/enabled", cfg.multicast_scouting)
    put("scouting/gossip/enabled", cfg.gossip)
    if cfg.mode == "peer":
        put("listen/endpoints", list(cfg.listen))
        put("listen/exit_on_failure", True)
    put("connect/endpoints", list(cfg.connect))
    if cfg.connect:
        put("connect/timeout_ms", int(round(cfg.connect_timeout_s * 1000)))
        put("connect/exit_on_failure", True)
        # Retry quickly so processes started together find each other within a fraction of a second.
        put("connect/retry", {"period_init_ms": 100, "period_max_ms": 1000, "period_increase_factor": 2})
    return zc


def open_session(cfg: TransportConfig | None = None) -> zenoh.Session:
    """Open a Zenoh session for ``cfg``; raises :class:`TransportError` if an endpoint fails.

    Use it as a context manager (``with open_session(cfg) as s:``) so it is closed on every
    path. Open sessions only in the process that uses them (spawn, never fork after open).
    """
    cfg = cfg or TransportConfig()
    zc = zenoh_config(cfg)
    try:
        return zenoh.open(zc)
    except zenoh.ZError as exc:
        where = ", ".join(cfg.connect + cfg.listen)
        raise TransportError(f"cannot open Zenoh session ({where}): {str(exc).splitlines()[0][:200]}") from None


def free_tcp_ports(n: int, host: str = "127.0.0.1") -> list[int]:
    """``n`` distinct TCP ports free on ``host`` right now (a later bind may still race)."""
    socks, ports = [], []
    try:
        for _ in range(n):
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.bind((host, 0))
            socks.append(s)
            ports.append(s.getsockname()[1])
    finally:
        for s in socks:
            s.close()
    return ports


def mesh_configs(
    roles: Sequence[str],
    base: TransportConfig | None = None,
    host: str = "127.0.0.1",
    ports: Sequence[int] | None = None,
    gossip: bool = False,
) -> dict[str, TransportConfig]:
    """A full mesh for processes started together (``navbank run``): one fixed port per role.

    Role ``i`` listens on its own port and connects to roles ``0..i-1``, so every pair has exactly
    one direct link. Gossip is off by default here: the mesh does not need it, and the links are
    then exactly the configured ones. Start the roles in the given order; a later role's connects
    are retried until ``connect_timeout_s``, and every earlier role must still be running then
    (a role that has already closed its session makes the later one fail to open).
    """
    base = base or TransportConfig()
    ports = list(ports) if ports is not None else free_tcp_ports(len(roles), host)
    if len(ports) != len(roles):
        raise ValueError(f"{len(roles)} roles but {len(ports)} ports")
    eps = [f"tcp/{host}:{p}" for p in ports]
    return {r: replace(base, listen=(eps[i],), connect=tuple(eps[:i]), gossip=gossip) for i, r in enumerate(roles)}


def add_transport_arguments(parser: argparse.ArgumentParser) -> None:
    """``--listen/--connect/--zenoh-config/--client/--no-gossip/--connect-timeout`` options."""
    g = parser.add_argument_group("transport (Zenoh)")
    g.add_argument("--listen", action="append", default=None, metavar="EP", help="endpoint to listen on (repeatable; default tcp/127.0.0.1:0)")
    g.add_argument("--connect", action="append", default=None, metavar="EP", help="endpoint to connect to (repeatable), e.g. tcp/127.0.0.1:7447")
    g.add_argument("--zenoh-config", default=None, metavar="FILE", help="Zenoh JSON5 config file (TLS, auth, access control)")
    g.add_argument("--client", action="store_true", help="client mode (connect through a Zenoh router)")
    g.add_argument("--no-gossip", action="store_true", help="do not discover peers through connected peers")
    g.add_argument("--connect-timeout", type=float, default=10.0, metavar="S", help="seconds allowed for every connect endpoint (default 10)")


def transport_config_from_args(args: argparse.Namespace) -> TransportConfig:
    """The :class:`TransportConfig` of options added by :func:`add_transport_arguments`."""
    default = TransportConfig()
    return TransportConfig(
        mode="client" if args.client else "peer",
        listen=tuple(args.listen) if args.listen else default.listen,
        connect=tuple(args.connect or ()),
        gossip=not args.no_gossip,
        config_file=args.zenoh_config,
        connect_timeout_s=args.connect_timeout,
    )


def _encoding(cls: type) -> zenoh.Encoding:
    return zenoh.Encoding.APPLICATION_JSON.with_schema(codec.schema_name(cls))


def _now_stamp() -> Stamp:
    return Stamp.from_unix(time.time())


# --------------------------------------------------------------------------------------------
# Publishing
# --------------------------------------------------------------------------------------------


class Publisher:
    """One ICD topic of one run: RELIABLE, congestion control BLOCK, JSON with schema name.

    ``count`` is the number of messages put; each put carries it (before increment) as an 8-byte
    little-endian attachment so subscribers can count gaps. ``credit`` windows, if given, are
    waited on before every put.
    """

    def __init__(
        self,
        session: zenoh.Session,
        run_id: str,
        topic: str,
        cls: type | None = None,
        *,
        credit: Sequence["CreditWindow"] = (),
        priority: zenoh.Priority | None = None,
    ):
        self.topic = topic.strip("/")
        self.key = topics.key(run_id, self.topic)
        try:
            expected = topics.type_of_topic(self.topic)
        except KeyError:
            expected = None
        if cls is None:
            if expected is None:
                raise ValueError(f"topic {self.topic!r} is not in the ICD topic table; pass its type")
            cls = expected
        elif expected is not None and cls is not expected:
            raise ValueError(f"topic {self.topic!r} carries {expected.__name__}, not {cls.__name__}")
        self.cls = cls
        self.count = 0
        self.credit = tuple(credit)
        self._pub = session.declare_publisher(
            self.key,
            encoding=_encoding(cls),
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
            priority=priority,
        )

    def put(self, msg: Any) -> None:
        """Encode and publish one message of this topic's type."""
        if not isinstance(msg, self.cls):
            raise TypeError(f"{self.topic} carries {self.cls.__name__}, got {type(msg).__name__}")
        self.put_payload(codec.to_json(msg))

    def put_payload(self, payload: bytes) -> None:
        """Publish an already encoded payload (replay of recorded bytes)."""
        for window in self.credit:
            window.wait(self.count)
        self._pub.put(payload, attachment=_SEQ.pack(self.count))
        self.count += 1

    @property
    def has_subscribers(self) -> bool:
        return bool(self._pub.matching_status)

    def close(self) -> None:
        self._pub.undeclare()

    def __enter__(self) -> "Publisher":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def end_of_run_counts(publishers: Iterable[Publisher], **extra: int) -> dict[str, int]:
    """``counts`` for an end-of-run RunStatus: messages per topic (keys with '/') plus ``extra``."""
    out = {p.topic: p.count for p in publishers}
    for k, v in extra.items():
        if "/" in k:
            raise ValueError(f"counter name {k!r} must not contain '/' (reserved for topics)")
        out[k] = int(v)
    return out


# --------------------------------------------------------------------------------------------
# Subscribing
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Received:
    """One sample taken from a :class:`Subscriber`."""

    topic: str  # key without the run prefix, e.g. "sim/measurements"
    payload: bytes
    receive_ns: int  # wall clock when taken from the channel, ns since the Unix epoch
    schema: str  # schema in the Zenoh encoding, e.g. "navbank.Measurement/v1" ('' if none)
    message: Any | None  # decoded ICD message (None if not decoded)
    pub_seq: int | None  # publisher sequence number from the attachment


class Subscriber:
    """Bounded-FIFO subscriber to topics of one run, with strict decoding and counters.

    ``topics`` are key expressions relative to the run (``"sim/measurements"``, ``"fsw/**"``,
    ``"**"``). With ``decode=True`` :meth:`recv` returns only messages that decode strictly;
    the others are counted in ``decode_errors`` (``last_error`` keeps the newest reason). With
    ``decode=False`` every sample is returned raw, except that RunStatus topics are always
    decoded so end-of-run statuses are tracked. ``received`` counts every sample taken, per
    topic; ``gaps`` counts publisher sequence numbers skipped. With ``role`` set, the progress
    queryable ``navbank/<run>/<role>/progress`` is served (see the module documentation).

    Close it (or use ``with``): the progress queryable uses a callback, and a declared callback
    keeps the process from exiting.
    """

    def __init__(
        self,
        session: zenoh.Session,
        run_id: str,
        topic_exprs: Sequence[str] | str = ("**",),
        *,
        decode: bool = True,
        role: str | None = None,
        capacity: int = 8192,
    ):
        if isinstance(topic_exprs, str):
            topic_exprs = (topic_exprs,)
        if not topic_exprs:
            raise ValueError("subscribe to at least one topic expression")
        self.run_id = topics.check_run_id(run_id)
        if role is not None and role not in ROLES:
            raise ValueError(f"role {role!r}: expected one of {', '.join(ROLES)}")
        self.role = role
        self.decode = decode
        self._prefix_len = len(topics.run_prefix(run_id)) + 1
        self._patterns = [zenoh.KeyExpr(topics.key(run_id, t)) for t in topic_exprs]
        self._lock = threading.Lock()
        self.received: dict[str, int] = {}
        self.decode_errors: dict[str, int] = {}
        self.gaps: dict[str, int] = {}
        self.last_error = ""
        self.end_of_run: dict[str, RunStatus] = {}
        self.acknowledged: dict[str, bool] = {}
        self.last_t_s = 0.0
        self._next_seq: dict[str, int] = {}
        self._subs: list[Any] = []
        self._queryable = None
        self._rr = 0
        try:
            for pattern in self._patterns:
                self._subs.append(session.declare_subscriber(pattern, zenoh.handlers.FifoChannel(capacity)))
            if role is not None:
                # Declared after the subscribers: a producer that gets a progress reply knows the
                # subscriptions are in place (declarations travel in order on the direct link).
                self._queryable = session.declare_queryable(topics.key(run_id, f"{role}/{PROGRESS}"), self._on_progress_query)
        except BaseException:
            self.close()
            raise

    # -- taking samples ------------------------------------------------------------------
    def _take(self) -> Any | None:
        n = len(self._subs)
        for i in range(n):
            sub = self._subs[(self._rr + i) % n]
            sample = sub.try_recv()
            if sample is not None:
                self._rr = (self._rr + i + 1) % n
                return sample
        return None

    def recv(self, timeout: float | None = None) -> Received | None:
        """Next sample (decoded unless ``decode=False``), or None after ``timeout`` seconds."""
        deadline = None if timeout is None else time.monotonic() + timeout
        pause = 20e-6
        while True:
            sample = self._take()
            if sample is not None:
                got = self._process(sample)
                if got is not None:
                    return got
                pause = 20e-6
                continue
            if deadline is not None:
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                time.sleep(min(pause, left))
            else:
                time.sleep(pause)
            pause = min(pause * 2, 2e-3)

    def __iter__(self) -> Iterator[Received]:
        """Samples until the subscriber is closed (blocks while idle)."""
        while self._subs:
            got = self.recv(timeout=0.1)
            if got is not None:
                yield got

    def drain_available(self) -> list[Received]:
        """Everything already waiting in the channels, without blocking."""
        out = []
        while (sample := self._take()) is not None:
            got = self._process(sample)
            if got is not None:
                out.append(got)
        return out

    def _process(self, sample: Any) -> Received | None:
        now = time.time_ns()
        key = str(sample.key_expr)
        topic = key[self._prefix_len :]
        payload = sample.payload.to_bytes()
        schema = ""
        enc = sample.encoding
        if enc is not None:
            text = str(enc)
            if ";" in text:
                schema = text.split(";", 1)[1]
        pub_seq = None
        att = sample.attachment
        if att is not None:
            raw = att.to_bytes()
            if len(raw) == _SEQ.size:
                pub_seq = _SEQ.unpack(raw)[0]
        with self._lock:
            self.received[topic] = self.received.get(topic, 0) + 1
            if pub_seq is not None:
                expected = self._next_seq.get(topic)
                if expected is not None and pub_seq > expected:
                    self.gaps[topic] = self.gaps.get(topic, 0) + (pub_seq - expected)
                self._next_seq[topic] = pub_seq + 1
        message = None
        try:
            cls = topics.type_of_topic(topic)
        except KeyError:
            cls = None
        if self.decode or cls is RunStatus:
            try:
                if cls is None:
                    raise codec.ICDError(topic, "", "a topic of the ICD", f"unknown topic {topic!r}")
                if schema and schema != codec.schema_name(cls):
                    raise codec.ICDError(cls.__name__, "", f"schema {codec.schema_name(cls)}", f"schema {schema}")
                message = codec.from_json(cls, payload)
            except codec.ICDError as exc:
                with self._lock:
                    self.decode_errors[topic] = self.decode_errors.get(topic, 0) + 1
                    self.last_error = f"{topic}: {exc}"
                if self.decode:
                    return None
            if isinstance(message, RunStatus) and message.state == "end-of-run":
                self.end_of_run[message.source] = message
            t_s = getattr(message, "t_s", None)
            if t_s is not None and math.isfinite(t_s):
                self.last_t_s = t_s
        return Received(topic, payload, now, schema, message, pub_seq)

    # -- completeness ----------------------------------------------------------------------
    def _subscribed(self, topic: str) -> bool:
        try:
            k = zenoh.KeyExpr(topics.key(self.run_id, topic))
        except (ValueError, zenoh.ZError):
            return False
        return any(p.includes(k) for p in self._patterns)

    def is_complete(self, status: RunStatus) -> bool:
        """Whether every topic announced in ``status.counts`` that we subscribe to is fully taken."""
        with self._lock:
            received = dict(self.received)
        for name, n in status.counts.items():
            if "/" in name and self._subscribed(name) and received.get(name, 0) < n:
                return False
        return True

    def finished(self, producers: Iterable[str]) -> bool:
        """Every producer in ``producers`` has published end-of-run and we have all it announced."""
        return all(p in self.end_of_run and self.is_complete(self.end_of_run[p]) for p in producers)

    def wait_acknowledged(self, producers: Iterable[str], timeout_s: float = 5.0, linger_s: float = 0.2) -> bool:
        """Before closing: wait until each producer's drain query was answered "complete".

        Keeps answering progress queries meanwhile (on Zenoh's thread); then lingers ``linger_s``
        so the last reply leaves before the session closes. False if a producer never asked.
        """
        producers = list(producers)
        deadline = time.monotonic() + timeout_s
        while not all(self.acknowledged.get(p) for p in producers):
            if time.monotonic() > deadline:
                return False
            time.sleep(0.01)
        time.sleep(linger_s)
        return True

    def counts(self) -> dict[str, int]:
        with self._lock:
            return dict(self.received)

    # -- progress queryable (zenoh thread) ---------------------------------------------------
    def _on_progress_query(self, query: Any) -> None:
        with query:  # drops the Query on exit so the querier is not left waiting
            try:
                counts = self.counts()
                payload = query.payload
                if payload is not None and len(payload.to_bytes()) > 0:
                    status = codec.from_json(RunStatus, payload.to_bytes())
                    done = self.is_complete(status)
                    counts[COMPLETE] = int(done)
                    if done:
                        self.acknowledged[status.source] = True
                reply = RunStatus(
                    t_s=self.last_t_s,
                    timestamp=_now_stamp(),
                    run_id=self.run_id,
                    source=self.role,  # type: ignore[arg-type]
                    state="running",
                    counts=counts,
                )
                query.reply(query.key_expr, codec.to_json(reply), encoding=_encoding(RunStatus))
            except Exception as exc:  # never let a bad query kill the zenoh callback thread
                try:
                    query.reply_err(f"progress query failed: {exc}"[:300])
                except Exception:
                    pass

    def close(self) -> None:
        """Undeclare everything (idempotent)."""
        if self._queryable is not None:
            try:
                self._queryable.undeclare()
            except zenoh.ZError:
                pass
            self._queryable = None
        for sub in self._subs:
            try:
                sub.undeclare()
            except zenoh.ZError:
                pass
        self._subs = []

    def __enter__(self) -> "Subscriber":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


# --------------------------------------------------------------------------------------------
# Progress queries: readiness, credit flow control, end-of-stream drain
# --------------------------------------------------------------------------------------------


def query_progress(
    session: zenoh.Session, run_id: str, role: str, status: RunStatus | None = None, timeout_s: float = 1.0
) -> RunStatus | None:
    """Ask consumer ``role`` for its progress (None if nobody answered in time)."""
    kwargs: dict[str, Any] = {"timeout": timeout_s}
    if status is not None:
        kwargs["payload"] = codec.to_json(status)
        kwargs["encoding"] = _encoding(RunStatus)
    answer = None
    for reply in session.get(topics.key(run_id, f"{role}/{PROGRESS}"), **kwargs):
        if reply.ok is not None and answer is None:
            try:
                answer = codec.from_json(RunStatus, reply.ok.payload.to_bytes())
            except codec.ICDError:
                continue
    return answer


def wait_for_consumers(session: zenoh.Session, run_id: str, roles: Iterable[str], timeout_s: float = 30.0) -> None:
    """Block until every consumer role answers its progress queryable (its subscriptions are up)."""
    pending = list(roles)
    deadline = time.monotonic() + timeout_s
    while pending:
        pending = [r for r in pending if query_progress(session, run_id, r, timeout_s=0.5) is None]
        if not pending:
            return
        if time.monotonic() > deadline:
            raise TransportError(f"run {run_id}: no answer from {', '.join(pending)} within {timeout_s:g} s")
        time.sleep(0.05)


class CreditWindow:
    """Keeps a producer at most ``window`` messages of ``topic`` ahead of consumer ``role``.

    The consumer's FIFO capacity must exceed ``window``: then its channel never fills, the Zenoh
    link never blocks, and BLOCK's 5 s give-up never triggers, however long the consumer stalls.
    The progress queryable is asked only when the window is used up, so a keeping-up consumer
    costs about one query per ``window`` messages. ``stall_timeout_s`` (None: wait forever)
    bounds how long the producer waits without any progress before raising
    :class:`TransportError`.
    """

    def __init__(
        self,
        session: zenoh.Session,
        run_id: str,
        role: str,
        topic: str,
        window: int = 1000,
        *,
        stall_timeout_s: float | None = 120.0,
        poll_s: float = 0.005,
    ):
        if window < 1:
            raise ValueError("window must be >= 1")
        self.session, self.run_id, self.role = session, run_id, role
        self.topic = topic.strip("/")
        self.window = window
        self.stall_timeout_s = stall_timeout_s
        self.poll_s = poll_s
        self.taken = 0  # consumer's last reported count on topic
        self.waits = 0  # number of times the window was exhausted
        self.queries = 0

    def wait(self, published: int) -> None:
        """Return when message number ``published`` (0-based) may be sent."""
        if published - self.taken < self.window:
            return
        self.waits += 1
        last_progress = time.monotonic()
        pause = self.poll_s
        while True:
            self.queries += 1
            reply = query_progress(self.session, self.run_id, self.role, timeout_s=1.0)
            if reply is not None:
                taken = reply.counts.get(self.topic, 0)
                if taken > self.taken:
                    self.taken = taken
                    last_progress = time.monotonic()
                    pause = self.poll_s
                if published - self.taken < self.window:
                    return
            if self.stall_timeout_s is not None and time.monotonic() - last_progress > self.stall_timeout_s:
                raise TransportError(
                    f"{self.role} took no {self.topic} message for {self.stall_timeout_s:g} s "
                    f"(taken {self.taken}, published {published})"
                )
            time.sleep(pause)
            pause = min(pause * 2, 0.1)


def drain(
    session: zenoh.Session, run_id: str, status: RunStatus, consumers: Iterable[str], timeout_s: float = 30.0
) -> dict[str, bool]:
    """End-of-stream handshake: wait until every consumer confirms it has taken what ``status`` announces.

    ``status`` is the end-of-run RunStatus just published (counts per topic). Returns, per
    consumer, whether it confirmed within ``timeout_s``. Close the session only afterwards.
    """
    pending = list(consumers)
    done = {c: False for c in pending}
    deadline = time.monotonic() + timeout_s
    pause = 0.005
    while pending:
        for c in list(pending):
            reply = query_progress(session, run_id, c, status, timeout_s=1.0)
            if reply is not None and reply.counts.get(COMPLETE) == 1:
                done[c] = True
                pending.remove(c)
        if not pending or time.monotonic() > deadline:
            break
        time.sleep(pause)
        pause = min(pause * 2, 0.1)
    return done


# --------------------------------------------------------------------------------------------
# Telecommands
# --------------------------------------------------------------------------------------------


def _best_effort_id(payload: bytes) -> str:
    try:
        data = json.loads(payload.decode("utf-8"), parse_constant=lambda t: None)
    except (UnicodeDecodeError, ValueError, RecursionError):
        return ""
    if isinstance(data, dict) and isinstance(data.get("id"), str):
        return data["id"][:200]
    return ""


class CommandServer:
    """Queryable on ``navbank/<run>/fsw/cmd`` turning Telecommands into TelecommandReplies.

    ``threaded=True``: the handler runs on Zenoh's thread as queries arrive (it must be thread
    safe). ``threaded=False``: queries wait in a FIFO until :meth:`poll` serves them on the
    caller's thread (e.g. at frame boundaries of the executive).

    Counters: ``served`` (valid commands answered), ``malformed`` (payloads rejected before the
    handler), ``handler_errors`` (handler raised or returned something else than a reply).
    """

    def __init__(
        self,
        session: zenoh.Session,
        run_id: str,
        handler: Callable[[Telecommand], TelecommandReply],
        *,
        threaded: bool = True,
    ):
        self.handler = handler
        self.served = 0
        self.malformed = 0
        self.handler_errors = 0
        self.last_error = ""
        self._lock = threading.Lock()
        k = topics.key(run_id, topics.FSW_COMMAND)
        self.threaded = threaded
        if threaded:
            self._queryable = session.declare_queryable(k, self._serve)
        else:
            self._queryable = session.declare_queryable(k, zenoh.handlers.FifoChannel(256))

    def _answer(self, payload: bytes | None, schema: str) -> TelecommandReply:
        if payload is None:
            self._count_malformed("no payload")
            return TelecommandReply(id="", ok=False, error="malformed telecommand: no payload")
        want = codec.schema_name(Telecommand)
        if schema and schema != want:
            self._count_malformed(f"schema {schema}")
            return TelecommandReply(id=_best_effort_id(payload), ok=False, error=f"malformed telecommand: schema {schema}, expected {want}")
        try:
            cmd = codec.from_json(Telecommand, payload)
        except codec.ICDError as exc:
            self._count_malformed(str(exc))
            return TelecommandReply(id=_best_effort_id(payload), ok=False, error=f"malformed telecommand: {exc}"[:500])
        try:
            reply = self.handler(cmd)
            if not isinstance(reply, TelecommandReply):
                raise TypeError(f"handler returned {type(reply).__name__}, not TelecommandReply")
            codec.to_json(reply)  # a reply with NaN would fail later, outside our control
        except Exception as exc:
            with self._lock:
                self.handler_errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
            return TelecommandReply(id=cmd.id, ok=False, error=f"command failed: {type(exc).__name__}: {exc}"[:500])
        with self._lock:
            self.served += 1
        return reply

    def _count_malformed(self, why: str) -> None:
        with self._lock:
            self.malformed += 1
            self.last_error = why[:300]

    def _serve(self, query: Any) -> None:
        with query:
            try:
                payload = query.payload.to_bytes() if query.payload is not None else None
                enc = query.encoding
                text = str(enc) if enc is not None else ""
                schema = text.split(";", 1)[1] if ";" in text else ""
                reply = self._answer(payload, schema)
                query.reply(query.key_expr, codec.to_json(reply), encoding=_encoding(TelecommandReply))
            except Exception as exc:
                with self._lock:
                    self.handler_errors += 1
                    self.last_error = f"{type(exc).__name__}: {exc}"
                try:
                    query.reply_err(f"telecommand server error: {exc}"[:300])
                except Exception:
                    pass

    def poll(self) -> int:
        """Serve every waiting command on this thread (``threaded=False``); returns how many."""
        if self.threaded or self._queryable is None:
            return 0
        n = 0
        while (query := self._queryable.try_recv()) is not None:
            self._serve(query)
            n += 1
        return n

    def status(self) -> dict[str, float]:
        with self._lock:
            return {"served": self.served, "malformed": self.malformed, "handler_errors": self.handler_errors}

    def close(self) -> None:
        if self._queryable is not None:
            try:
                self._queryable.undeclare()
            except zenoh.ZError:
                pass
            self._queryable = None

    def __enter__(self) -> "CommandServer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def declare_command_server(
    session: zenoh.Session,
    run_id: str,
    handler: Callable[[Telecommand], TelecommandReply],
    *,
    threaded: bool = True,
) -> CommandServer:
    """Serve telecommands of run ``run_id`` with ``handler`` (see :class:`CommandServer`)."""
    return CommandServer(session, run_id, handler, threaded=threaded)


def send_command(session: zenoh.Session, run_id: str, cmd: Telecommand, timeout_s: float = 2.0) -> TelecommandReply:
    """Send a telecommand and return the FSW's reply; :class:`TransportError` if none comes."""
    if not isinstance(cmd, Telecommand):
        raise TypeError(f"expected a Telecommand, got {type(cmd).__name__}")
    return send_command_payload(session, run_id, codec.to_json(cmd), timeout_s=timeout_s)


def send_command_payload(
    session: zenoh.Session,
    run_id: str,
    payload: bytes,
    *,
    schema: str | None = codec.schema_name(Telecommand),
    timeout_s: float = 2.0,
) -> TelecommandReply:
    """Send a hand-made telecommand payload (e.g. JSON typed by an operator) as-is.

    ``schema`` goes into the Zenoh encoding (None: plain JSON without a schema name).
    """
    encoding = zenoh.Encoding.APPLICATION_JSON if schema is None else zenoh.Encoding.APPLICATION_JSON.with_schema(schema)
    errors = []
    answer = None
    for reply in session.get(topics.key(run_id, topics.FSW_COMMAND), payload=payload, encoding=encoding, timeout=timeout_s):
        if reply.ok is not None:
            if answer is None:
                try:
                    answer = codec.from_json(TelecommandReply, reply.ok.payload.to_bytes())
                except codec.ICDError as exc:
                    errors.append(f"unreadable reply: {exc}")
        elif reply.err is not None:
            errors.append(reply.err.payload.to_bytes().decode("utf-8", "replace"))
    if answer is not None:
        return answer
    if errors:
        raise TransportError(f"telecommand to run {run_id} failed: {'; '.join(errors)[:300]}")
    raise TransportError(f"no FSW of run {run_id} answered the telecommand within {timeout_s:g} s")

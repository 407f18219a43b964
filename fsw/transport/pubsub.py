"""Typed publish/subscribe of ICD topics of one run, without loss on a live link.

* **No loss on a live link.** Publishers are RELIABLE with congestion control BLOCK (the default,
  DROP, lost 33–93 % of messages of 64 B and more between two processes) and stamp a
  per-publisher sequence number in the attachment (:mod:`fsw.transport.wire`); subscribers
  count gaps.
* **No exit hang.** Subscribers take samples from bounded FIFO channels: no Python callback on
  the data path, since a declared callback keeps a process from exiting. The one callback, the
  progress queryable, is undeclared by :meth:`Subscriber.close`.
* **Progress.** A subscriber with a ``role`` serves that role's progress queryable, through
  which producers pace themselves and end their stream (:mod:`fsw.transport.flow`).
* **Authenticated statuses.** With the run's key (:mod:`fsw.interface.auth`) a publisher signs
  every RunStatus it puts, and a subscriber acts only on statuses with a valid tag: a forged
  end-of-run status (or drain query) is counted in ``refused`` and ends nothing.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import zenoh

from fsw.interface import codec, topics
from fsw.interface.auth import AUTHENTICATED_TYPES, MessageAuthenticator
from fsw.interface.frozen import fast_init
from fsw.interface.messages import RunStatus
from fsw.transport import wire
from fsw.transport.flow import COMPLETE, PROGRESS, ROLES, CreditWindow


#: Waiting on empty channels: zenoh's FIFO channel has no receive with a timeout (only a blocking
#: recv() without one, which would leave telecommands and the stop flag unattended), so an idle
#: subscriber sleeps between looks. Starting at 0.2 ms (not 20 us) keeps the wake-ups of a
#: consumer that keeps up with its producers to a few per message gap; the FIFO holds thousands
#: of messages, so nothing waits on the sleeper but latency, and no consumer here needs it.
_FIRST_PAUSE_S = 2e-4
_LONGEST_PAUSE_S = 4e-3


class TopicPublisher(Protocol):
    """What the lifecycle needs of a publisher: a :class:`Publisher`, or one a process makes
    itself for a topic outside the ICD."""

    topic: str
    count: int

    def put_payload(self, payload: bytes) -> None: ...

    def close(self) -> None: ...


class ConsumerHold:
    """Holds a producer's puts while a consumer that was there has gone (a logger being restarted).

    ``sentinel`` is a publisher only that consumer subscribes to (the simulator's truth, the
    FSW's status): once it has matched a subscriber, a put made while it matches none waits until
    one is back, at most ``timeout_s`` per absence (then it stops holding: a consumer that does
    not come back must not stop the run). Whether it matches is kept current by a matching
    listener on the sentinel (asking Zenoh on every put cost ~3 µs, 0.2 s of CPU over a default
    run's 66k puts); while it matches none, the wait polls Zenoh's own status."""

    def __init__(self, sentinel: "Publisher", timeout_s: float = 60.0, poll_s: float = 0.01):
        self.sentinel, self.timeout_s, self.poll_s = sentinel, timeout_s, poll_s
        self.seen = False
        self.holds = 0  # absences waited out (or given up on)
        self.held_s = 0.0
        self.gave_up = False
        self._lock = threading.Lock()
        self._matching: bool | None = None  # None: no status from the listener yet
        self._listener = sentinel.on_matching(self._on_matching)
        with self._lock:
            if self._matching is None:  # the listener's first status, if it came, is newer
                self._matching = sentinel.matched

    def _on_matching(self, matching: bool) -> None:
        with self._lock:
            self._matching = matching

    def wait(self) -> None:
        if self.gave_up:
            return
        if self._matching:
            self.seen = True
            return
        if not self.seen:
            return  # nobody was there yet: nothing to wait for
        self.holds += 1
        t0 = time.monotonic()
        while not self.sentinel.matched:
            if time.monotonic() - t0 > self.timeout_s:
                self.gave_up = True
                break
            time.sleep(self.poll_s)
        self.held_s += time.monotonic() - t0


class Publisher:
    """One ICD topic of one run: RELIABLE, congestion control BLOCK, JSON with schema name.

    ``count`` is the number of messages put; each put carries it (before increment) as an 8-byte
    little-endian attachment so subscribers can count gaps. ``credit`` windows, if given, are
    waited on before every put. With an ``authenticator``, messages of the authenticated types
    are signed as they are put.
    """

    def __init__(
        self,
        session: zenoh.Session,
        run_id: str,
        topic: str,
        cls: type | None = None,
        *,
        credit: Sequence[CreditWindow] = (),
        priority: zenoh.Priority | None = None,
        authenticator: MessageAuthenticator | None = None,
    ):
        self.topic = topic.strip("/")
        self.authenticator = authenticator
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
        self.hold: ConsumerHold | None = None
        self._pub = session.declare_publisher(
            self.key,
            encoding=wire.encoding(cls),
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
            priority=priority,
        )

    def put(self, msg: Any) -> None:
        """Encode and publish one message of this topic's type."""
        if not isinstance(msg, self.cls):
            raise TypeError(f"{self.topic} carries {self.cls.__name__}, got {type(msg).__name__}")
        if self.authenticator is not None and isinstance(msg, AUTHENTICATED_TYPES):
            msg = self.authenticator.sign(msg)
        self.put_payload(codec.to_json(msg))

    def put_payload(self, payload: bytes) -> None:
        """Publish an already encoded payload (replay of recorded bytes)."""
        if self.hold is not None:
            self.hold.wait()
        for window in self.credit:
            window.wait(self.count)
        self._pub.put(payload, attachment=wire.sequence_attachment(self.count))
        self.count += 1

    @property
    def has_subscribers(self) -> bool:
        return bool(self._pub.matching_status)

    def on_matching(self, callback: Callable[[bool], None]) -> Any:
        """Call ``callback(matching)`` whenever whether some subscriber matches this publisher
        changes; returns the listener (it lives as long as it is referenced)."""
        return self._pub.declare_matching_listener(lambda status: callback(bool(status.matching)))

    @property
    def matched(self) -> bool:
        """Some subscriber matches this publisher now."""
        status: Any = self._pub.matching_status  # a MatchingStatus (the stubs say bool)
        return bool(status.matching)

    def close(self) -> None:
        self._pub.undeclare()

    def __enter__(self) -> "Publisher":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def end_of_run_counts(publishers: Iterable[TopicPublisher], **extra: int) -> dict[str, int]:
    """``counts`` for an end-of-run RunStatus: messages per topic (keys with '/') plus ``extra``."""
    out = {p.topic: p.count for p in publishers}
    for k, v in extra.items():
        if "/" in k:
            raise ValueError(f"counter name {k!r} must not contain '/' (reserved for topics)")
        out[k] = int(v)
    return out


class SeenSequences:
    """The sequence numbers seen on one topic, one bit each (a run's topics stay in the millions)."""

    def __init__(self) -> None:
        self._bits = bytearray()

    def add(self, seq: int) -> bool:
        """Mark ``seq`` seen; False if it was seen already."""
        if seq < 0:
            return True  # not a sequence number of ours: never a duplicate
        byte, bit = divmod(seq, 8)
        if byte >= len(self._bits):
            self._bits.extend(bytes(max(byte + 1 - len(self._bits), len(self._bits))))
        if self._bits[byte] >> bit & 1:
            return False
        self._bits[byte] |= 1 << bit
        return True

    def __contains__(self, seq: int) -> bool:
        byte, bit = divmod(seq, 8)
        return 0 <= byte < len(self._bits) and bool(self._bits[byte] >> bit & 1)


@fast_init  # one per sample taken (the logger takes ~100k a default run): 1.25 -> 0.65 us each
@dataclass(frozen=True, slots=True)
class Received:
    """One sample taken from a :class:`Subscriber`."""

    topic: str  # key without the run prefix, e.g. "sim/measurements"
    payload: bytes
    receive_ns: int  # wall clock when taken from the channel, ns since the Unix epoch
    schema: str  # schema in the Zenoh encoding, e.g. "navbank.Measurement/v1" ('' if none)
    message: Any | None  # decoded ICD message (None if not decoded)
    pub_seq: int | None  # publisher sequence number from the attachment
    refused: str = ""  # why its authentication failed ('' if it passed or was not checked)


class Subscriber:
    """Bounded-FIFO subscriber to topics of one run, with strict decoding and counters.

    ``topics`` are key expressions relative to the run (``"sim/measurements"``, ``"fsw/**"``,
    ``"**"``). With ``decode=True`` :meth:`recv` returns only messages that decode strictly;
    the others are counted in ``decode_errors`` (``last_error`` keeps the newest reason). With
    ``decode=False`` every sample is returned raw, except that RunStatus topics are always
    decoded so end-of-run statuses are tracked. ``received`` counts every sample taken, per
    topic; ``gaps`` counts publisher sequence numbers skipped. With ``role`` set, the progress
    queryable ``navbank/<run>/<role>/progress`` is served (see :mod:`fsw.transport.flow`).
    With an ``authenticator`` a RunStatus without a valid tag — published, or sent as a drain
    query — is counted in ``refused`` (per topic) and changes nothing: with ``decode=False`` it
    is still returned, with its ``refused`` reason, so a recorder can keep it apart.

    With ``batch`` > 1 :meth:`recv` takes up to that many samples at once when it finds none
    already taken, and hands them out one by one: the per-sample work (key, encoding, sequence
    number, counters) then runs back to back instead of between two measurements' worth of a
    consumer's own work, with cold caches — 13.8 against 8.0 µs per sample measured in the FSW
    process of ``navbank run``. A sample taken counts as received (in ``received``, progress
    replies and completeness) from then on, as one :meth:`recv` returned does: it is in this
    process either way. :meth:`drain_available` returns the ones taken but not yet handed out first.

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
        resume: dict[str, int] | None = None,
        dedupe: bool = False,
        settle_s: float | None = None,
        authenticator: MessageAuthenticator | None = None,
        batch: int = 1,
    ):
        if isinstance(topic_exprs, str):
            topic_exprs = (topic_exprs,)
        if not topic_exprs:
            raise ValueError("subscribe to at least one topic expression")
        self.run_id = topics.check_run_id(run_id)
        if role is not None and role not in ROLES:
            raise ValueError(f"role {role!r}: expected one of {', '.join(ROLES)}")
        self.role = role
        if batch < 1:
            raise ValueError(f"batch must be at least 1, got {batch}")
        self.batch = batch
        self._taken: deque[Received] = deque()  # taken in a batch, not yet handed out
        self.decode = decode
        self.authenticator = authenticator
        self.refused: dict[str, int] = {}
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
        # A restarted consumer takes a topic again from where its checkpoint stood: the count of
        # what it had taken, and nothing but the next sequence number in order (what the producer
        # sent before it heard of the restart is discarded; it sends it again).
        self._in_order = dict(resume or {})
        for topic, n in self._in_order.items():
            self.received[topic] = self._next_seq[topic] = int(n)
        self.discarded: dict[str, int] = {}
        #: with ``dedupe``, the sequence numbers seen per topic: a sample seen before (a producer
        #: that resends after a restart) is dropped and counted in ``duplicates``
        self.seen: dict[str, SeenSequences] | None = {} if dedupe else None
        self.duplicates: dict[str, int] = {}
        #: further counters every progress reply carries (e.g. a restarted consumer's incarnation)
        self.progress_extra: dict[str, int] = {}
        # A recorder restarted after messages went by unrecorded can never take everything
        # announced: with ``settle_s`` a topic counts as complete once nothing has arrived for
        # that long (what is still missing is lost, and the recorder says so).
        self.settle_s = settle_s
        self._last_sample = time.monotonic()
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
        taken = self._taken
        if taken:
            return taken.popleft()
        deadline = None if timeout is None else time.monotonic() + timeout
        pause = _FIRST_PAUSE_S
        while True:
            sample = self._take()
            if sample is not None:
                got = self._process(sample)
                if self.batch > 1:
                    if got is not None:
                        taken.append(got)
                    self._take_more(self.batch - 1)
                    if taken:
                        return taken.popleft()
                elif got is not None:
                    return got
                pause = _FIRST_PAUSE_S
                continue
            if deadline is not None:
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                time.sleep(min(pause, left))
            else:
                time.sleep(pause)
            pause = min(pause * 2, _LONGEST_PAUSE_S)

    def __iter__(self) -> Iterator[Received]:
        """Samples until the subscriber is closed (blocks while idle)."""
        while self._subs:
            got = self.recv(timeout=0.1)
            if got is not None:
                yield got

    def next_taken(self, topic: str) -> list[Received]:
        """The samples of ``topic`` next in line among those a batch has taken already (none
        read from the channels): a consumer may handle a run of them together."""
        taken = self._taken
        out = []
        while taken and taken[0].topic == topic:
            out.append(taken.popleft())
        return out

    def _take_more(self, n: int) -> None:
        """Take up to ``n`` more samples already waiting into the batch handed out next."""
        taken = self._taken
        for _ in range(n):
            sample = self._take()
            if sample is None:
                return
            got = self._process(sample)
            if got is not None:
                taken.append(got)

    def drain_available(self) -> list[Received]:
        """Everything already waiting, without blocking: what a batch took and :meth:`recv` did not
        yet hand out, then what is in the channels."""
        out = list(self._taken)
        self._taken.clear()
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
        schema = wire.schema_of(sample.encoding)
        pub_seq = wire.sequence_of(sample.attachment)
        try:
            cls = topics.type_of_topic(topic)
        except KeyError:
            cls = None
        if self.authenticator is not None and cls is RunStatus:
            # authenticated before it counts for anything: a forged status must not take the place
            # of the producer's own (its sequence number, or a repeat of it)
            try:
                status: RunStatus | None = codec.from_json(RunStatus, payload)
            except codec.ICDError:
                status = None  # counted as a decode error below
            if status is not None and (why := self.authenticator.refusal(status)):
                self._count_refused(topic, why)
                return None if self.decode else Received(topic, payload, now, schema, status, pub_seq, why)
        with self._lock:
            self._last_sample = time.monotonic()
            if topic in self._in_order and pub_seq != self._next_seq[topic]:
                self.discarded[topic] = self.discarded.get(topic, 0) + 1
                return None
            if self.seen is not None and pub_seq is not None:
                seen = self.seen.setdefault(topic, SeenSequences())
                if not seen.add(pub_seq):
                    self.duplicates[topic] = self.duplicates.get(topic, 0) + 1
                    return None
            self.received[topic] = self.received.get(topic, 0) + 1
            if pub_seq is not None:
                expected = self._next_seq.get(topic)
                if expected is not None and pub_seq > expected:
                    self.gaps[topic] = self.gaps.get(topic, 0) + (pub_seq - expected)
                if self.seen is not None and expected is not None and pub_seq < expected:
                    self.gaps[topic] = self.gaps.get(topic, 0) - 1  # a gap filled late
                else:
                    self._next_seq[topic] = pub_seq + 1
        message: object | None = None
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

    def _count_refused(self, topic: str, why: str) -> None:
        with self._lock:
            self.refused[topic] = self.refused.get(topic, 0) + 1
            self.last_error = f"{topic}: refused: {why}"

    # -- completeness ----------------------------------------------------------------------
    def subscribed(self, topic: str) -> bool:
        """Whether ``topic`` is among this subscriber's topics."""
        return self._subscribed(topic)

    def _subscribed(self, topic: str) -> bool:
        try:
            k = zenoh.KeyExpr(topics.key(self.run_id, topic))
        except (ValueError, zenoh.ZError):
            return False
        return any(p.includes(k) for p in self._patterns)

    def is_complete(self, status: RunStatus) -> bool:
        """Whether every topic announced in ``status.counts`` that we subscribe to is fully taken
        (or, with ``settle_s``, nothing more has come for that long)."""
        with self._lock:
            received = dict(self.received)
            settled = self.settle_s is not None and time.monotonic() - self._last_sample >= self.settle_s
        for name, n in status.counts.items():
            if "/" in name and self._subscribed(name) and received.get(name, 0) < n and not settled:
                return False
        return True

    def next_sequence(self, topic: str) -> int:
        """One past the highest publisher sequence number taken on ``topic`` (0 before any)."""
        with self._lock:
            return self._next_seq.get(topic, 0)

    def preload(self, topic: str, sequences: Iterable[int]) -> None:
        """Count ``sequences`` of ``topic`` as taken already (recorded by an earlier recorder of
        the run): with ``dedupe`` they are not taken again."""
        with self._lock:
            for seq in sequences:
                if self.seen is not None and not self.seen.setdefault(topic, SeenSequences()).add(seq):
                    continue
                self.received[topic] = self.received.get(topic, 0) + 1
                self._next_seq[topic] = max(self._next_seq.get(topic, 0), seq + 1)

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
                counts.update(self.progress_extra)
                payload = query.payload
                if payload is not None and len(payload.to_bytes()) > 0:
                    status = codec.from_json(RunStatus, payload.to_bytes())
                    why = self.authenticator.refusal(status) if self.authenticator is not None else None
                    if why is not None:
                        self._count_refused(f"{self.role}/{PROGRESS}", why)
                    elif status.state == "end-of-run" and status.source not in self.end_of_run:
                        # a consumer restarted after the producer's end-of-run went out learns it here
                        self.end_of_run[status.source] = status
                    done = why is None and self.is_complete(status)
                    counts[COMPLETE] = int(done)
                    if done:
                        self.acknowledged[status.source] = True
                reply = RunStatus(
                    t_s=self.last_t_s,
                    timestamp=wire.now_stamp(),
                    run_id=self.run_id,
                    source=self.role,  # type: ignore[arg-type]
                    state="running",
                    counts=counts,
                )
                query.reply(query.key_expr, codec.to_json(reply), encoding=wire.encoding(RunStatus))
            except Exception as exc:  # never let a bad query kill the zenoh callback thread
                try:
                    query.reply_err(f"progress query failed: {exc}"[:300])
                except Exception:
                    pass

    def close(self) -> None:
        """Undeclare everything (idempotent)."""
        if self._queryable is not None:
            wire.undeclare_quietly(self._queryable)
            self._queryable = None
        for sub in self._subs:
            wire.undeclare_quietly(sub)
        self._subs = []

    def __enter__(self) -> "Subscriber":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

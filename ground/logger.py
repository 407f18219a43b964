"""``navbank ground log``: record every message of one run into one MCAP file.

Subscribes to ``navbank/<run-id>/**`` and writes each sample as it is taken: ICD topics on
channels with their JSON Schema, unknown topics on schema-less ``json`` channels (counted), and
payloads that fail strict decoding on ``/_invalid/<topic>`` channels as raw bytes (counted) —
nothing delivered is dropped. With the run's key, a status whose authentication fails (a forged
end-of-run status) goes to ``/_refused/<topic>`` (counted) and ends nothing. The logger serves the ``ground`` progress queryable, so producers
can :func:`~fsw.transport.drain` into it before they close.

It stops

* by itself once every expected producer (default ``sim`` and ``fsw``) has published its
  end-of-run RunStatus and everything that status announces has been recorded — then it lingers
  until each producer's drain query has been answered (at most ``linger_s``);
* on SIGINT/SIGTERM, ``stop_event`` or ``max_duration_s``.

Every way out finishes the file (summary and footer). A SIGKILL cannot be caught: the file then
has no footer, but chunks are closed every ``flush_interval_s``, so
:func:`ground.mcap_io.read_messages` reads all but the last fraction of a second and
:func:`ground.mcap_io.recover` rewrites it into a complete file.
"""

from __future__ import annotations

import json
import os
import socket
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import msgspec

import fsw.transport as tp
from fsw.interface import codec, topics
from fsw.interface.messages import SCHEMA_VERSION, RunStatus
from ground.foxglove.live import LiveView
from ground.foxglove.tap import FoxgloveTap
from ground.foxglove.view import FoxgloveView, wanted
from ground.mcap_io import segments
from ground.mcap_io.recorder import INVALID_PREFIX, REFUSED_PREFIX, McapRecorder, publish_time_of

#: samples the logger takes from its subscription at once (see fsw.transport.Subscriber): the
#: per-sample transport work then runs back to back — its main thread's CPU over a default
#: ``navbank run`` fell from 4.05-4.26 to 3.70-3.77 s (one run of three at 4.42) with 64
RECEIVE_BATCH = 64

_MEDIA_TYPES = {".yaml": "application/yaml", ".yml": "application/yaml", ".json": "application/json", ".txt": "text/plain"}


@dataclass
class LogResult:
    """What a logging run recorded."""

    path: str
    ended_by: str  # "end-of-run", "signal", "stop", "duration"
    elapsed_s: float
    counts: dict[str, int] = field(default_factory=dict)  # messages per MCAP topic
    unknown: dict[str, int] = field(default_factory=dict)  # messages on topics outside the ICD
    invalid: dict[str, int] = field(default_factory=dict)  # payloads that failed strict decoding
    gaps: dict[str, int] = field(default_factory=dict)  # publisher sequence numbers never received
    refused: dict[str, int] = field(default_factory=dict)  # statuses and drain queries whose authentication failed
    duplicates: dict[str, int] = field(default_factory=dict)  # samples received again (same topic and number): dropped
    finished: tuple[str, ...] = ()  # producers whose end-of-run was fully recorded

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def report(self) -> str:
        lines = [f"navbank ground log: {self.total} messages -> {self.path} ({self.ended_by}, {self.elapsed_s:.1f} s)"]
        width = max((len(t) for t in self.counts), default=0)
        lines += [f"  {t:<{width}}  {n:>9}" for t, n in sorted(self.counts.items())]
        for label, table in (("unknown topics", self.unknown), ("invalid payloads", self.invalid), ("gaps (lost)", self.gaps),
                             ("duplicates (dropped)", self.duplicates), ("refused (authentication)", self.refused)):
            if table:
                lines.append(f"  {label}: " + ", ".join(f"{t}={n}" for t, n in sorted(table.items())))
        if self.finished:
            lines.append("  end-of-run recorded for: " + ", ".join(self.finished))
        return "\n".join(lines)


def _attachment_items(attachments: Iterable[str | os.PathLike | tuple[str, bytes, str]]) -> list[tuple[str, bytes, str]]:
    items = []
    for a in attachments:
        if isinstance(a, tuple):
            items.append(a)
        else:
            p = os.fspath(a)
            with open(p, "rb") as f:
                data = f.read()
            items.append((os.path.basename(p), data, _MEDIA_TYPES.get(os.path.splitext(p)[1].lower(), "application/octet-stream")))
    return items


class _Writer:
    """Turns samples into MCAP records with the bookkeeping of a :class:`LogResult`.

    ``log_time`` is the message's mission time (its ``timestamp``) when ``mission_time`` — so a
    player follows the mission — and a message without one (unknown or invalid payloads) gets
    the latest mission time seen; otherwise the receive time."""

    def __init__(self, rec: McapRecorder, validate: bool, mission_time: bool = True, tap: FoxgloveTap | None = None,
                 feed: Callable[[str, type, bytes, Any, int], None] | None = None):
        self.rec = rec
        self.validate = validate
        self.mission_time = mission_time
        self.tap = tap
        self.feed = feed
        self._mission_ns: int | None = None
        self.unknown: dict[str, int] = {}
        self.invalid: dict[str, int] = {}
        self.ends: set[str] = set()  # producers whose end-of-run status was recorded
        self._reading: dict[str, str] = {}  # per ICD topic: how its payloads are read (_read_as)

    def _read_as(self, topic: str) -> str:
        """How the payloads of ICD topic ``topic`` are read, decided once per topic: ``typed``
        (strictly, when validating, or when the feed keeps its ICD objects and would decode them
        strictly itself), ``json`` (the JSON value, for the Foxglove view or a feed that does not
        say what it keeps) or ``stamp`` (only the timestamp: nothing else reads the message).

        Without validation, every payload used to be parsed into its JSON value and the feed's
        topics decoded again: 5.3 s of CPU for a default run's 101,323 messages offline, of which
        the JSON values cost 12 % and the feed's decoding 14 %."""
        how = self._reading.get(topic)
        if how is None:
            feed_reads = getattr(self.feed, "reads", None)
            view = None if self.tap is None else self.tap.view
            if self.validate or (feed_reads is not None and feed_reads(topic)):
                how = "typed"
            elif (self.feed is not None and feed_reads is None) or (view is not None and wanted(topic)):
                how = "json"
            else:
                how = "stamp"
            self._reading[topic] = how
        return how

    def _log_time(self, receive_ns: int, publish_ns: int | None) -> int:
        if not self.mission_time:
            return receive_ns
        if publish_ns is not None:
            self._mission_ns = publish_ns
            return publish_ns
        return receive_ns if self._mission_ns is None else self._mission_ns

    def _invalid(self, got: tp.Received) -> None:
        self.invalid[got.topic] = self.invalid.get(got.topic, 0) + 1
        self.rec.write(f"{INVALID_PREFIX}/{got.topic}", got.payload, self._log_time(got.receive_ns, None), None,
                       got.pub_seq or 0)

    def __call__(self, got: tp.Received) -> None:
        if got.refused:
            self.rec.write(f"{REFUSED_PREFIX}/{got.topic}", got.payload, got.receive_ns, None, got.pub_seq or 0)
            return
        try:
            cls = topics.type_of_topic(got.topic)
        except KeyError:
            cls = None
        message: Any = got.message
        publish_ns: int | None = None
        if cls is None:
            self.unknown[got.topic] = self.unknown.get(got.topic, 0) + 1
            try:
                message = _parse_json(got.payload)
            except ValueError:
                self._invalid(got)
                return
        elif message is None:
            how = self._read_as(got.topic)
            try:
                if got.schema and got.schema != codec.schema_name(cls):
                    raise ValueError(f"schema {got.schema}")
                if self.validate:
                    message = codec.from_json(cls, got.payload)
                elif how == "typed":
                    try:
                        message = codec.from_json(cls, got.payload)
                    except codec.ICDError:  # recorded all the same, as its JSON value (the feed is then spoiled)
                        message = _parse_json(got.payload)
                elif how == "stamp":
                    publish_ns = _stamp_only(got.payload)
                    if publish_ns is None:
                        message = _parse_json(got.payload)
                else:
                    message = _parse_json(got.payload)
            except ValueError:  # ICDError is a ValueError, and so is a JSON syntax error
                self._invalid(got)
                return
        if publish_ns is None:
            publish_ns = publish_time_of(message)
        log_ns = self._log_time(got.receive_ns, publish_ns)
        self.rec.write(got.topic, got.payload, log_ns, publish_ns, got.pub_seq or 0)
        if self.tap is not None:
            self.tap(got.topic, cls, got.payload, message, log_ns)
        if self.feed is not None and cls is not None:
            self.feed(got.topic, cls, got.payload, message, log_ns)
        if isinstance(message, RunStatus) and message.state == "end-of-run":
            self.ends.add(message.source)


class _Stamp(msgspec.Struct):
    sec: int
    nsec: int


class _Stamped(msgspec.Struct):
    timestamp: _Stamp


_STAMPED = msgspec.json.Decoder(_Stamped)


def _stamp_only(payload: bytes) -> int | None:
    """:func:`~ground.mcap_io.recorder.publish_time_of` a payload's JSON value, read without
    making the value: the timestamp's two integers, every other member skipped (but parsed: a
    syntax error anywhere refuses the payload). None where that cannot tell — another shape, or a
    payload that only ``json.loads`` takes — and the caller then makes the JSON value."""
    try:
        ts = _STAMPED.decode(payload).timestamp
    except (msgspec.DecodeError, msgspec.ValidationError):
        return None
    sec, nsec = ts.sec, ts.nsec
    return sec * 1_000_000_000 + nsec if sec >= 0 and 0 <= nsec < 1_000_000_000 else None


def _parse_json(payload: bytes) -> Any:
    """The JSON value of a payload not validated against its type: msgspec parses the same values
    as ``json.loads`` several times faster; what it refuses (NaN or Infinity tokens, a lone
    surrogate) ``json.loads`` judges as before."""
    try:
        return msgspec.json.decode(payload)
    except msgspec.DecodeError:
        return json.loads(payload)


def _record_announced_ends(sub: tp.Subscriber, write: _Writer, producers: Sequence[str],
                           after: Sequence[str | os.PathLike]) -> None:
    """A producer's end-of-run status that went by while no logger was up still reached this one
    as the payload of the producer's drain query: record it, so the recording ends with the
    producer's final counters (its own status message, stamped with the time it was learnt)."""
    recorded = set(segments.recorded(after).end_of_run) if after else set()
    recorded |= write.ends
    for p in producers:
        status = sub.end_of_run.get(p)
        if status is None or p in recorded:
            continue
        topic = f"{p}/status"
        # the FSW counts its statuses before the end one; the simulator's comes after the highest seen
        seq = status.counts.get(topic, sub.next_sequence(topic))
        write(tp.Received(topic, codec.to_json(status), time.time_ns(), codec.schema_name(type(status)), status, seq))


def _gaps(sub: tp.Subscriber, producers: Sequence[str]) -> dict[str, int]:
    """Publisher sequence numbers never recorded, per topic: for what an end-of-run announced,
    the shortfall against it (it also covers the tail a dead logger missed); else the numbers
    skipped."""
    gaps = {t: n for t, n in sub.gaps.items() if n > 0}
    received = sub.counts()
    for p in producers:
        status = sub.end_of_run.get(p)
        if status is None:
            continue
        for t, n in status.counts.items():
            if "/" not in t or not sub.subscribed(t):
                continue
            # a producer counts its statuses before the end-of-run one, which comes on top
            expected = n + 1 if t == f"{p}/status" else n
            gaps.pop(t, None)
            if received.get(t, 0) < expected:
                gaps[t] = expected - received.get(t, 0)
    return gaps


def run_logger(
    run_id: str,
    out_path: str | os.PathLike,
    transport_cfg: tp.TransportConfig | None = None,
    *,
    stop_event: tp.StopFlag | None = None,
    producers: Sequence[str] = ("sim", "fsw"),
    until_end_of_run: bool = True,
    max_duration_s: float | None = None,
    linger_s: float = 2.0,
    validate: bool = True,
    metadata: Mapping[str, Any] | None = None,
    attachments: Iterable[str | os.PathLike | tuple[str, bytes, str]] = (),
    flush_interval_s: float = 0.5,
    chunk_size: int = 64 * 1024,
    capacity: int = 16384,
    handle_signals: bool = True,
    ready_event: Any = None,
    print_fn: Callable[[str], None] | None = print,
    after: Sequence[str | os.PathLike] = (),
    settle_s: float = 2.0,
    mission_time: bool = True,
    foxglove_channels: bool = True,
    live: tuple[str, int] | None = None,
    feed: Callable[[str, type, bytes, Any, int], None] | None = None,
    on_closed: Callable[[LogResult], None] | None = None,
) -> LogResult:
    """Record run ``run_id`` into ``out_path`` until it ends or is stopped (see module doc).

    ``stop_event`` and ``ready_event`` are anything with ``is_set()`` / ``set()``
    (threading or multiprocessing events); ``ready_event`` is set once the subscription is up.
    ``attachments`` are file paths or ``(name, data, media_type)`` tuples (e.g. the scenario
    YAML); ``metadata`` goes into the ``navbank.run`` metadata record next to the run id.

    ``after`` names the earlier segments of the same run (a logger restarted after the previous
    one died, :mod:`ground.mcap_io.segments`): what they hold is not recorded again, the
    end-of-run statuses they hold count, and what went by while no logger was up is lost —
    counted in ``gaps`` once nothing more has arrived for ``settle_s``.
    ``mission_time``: ``log_time`` is each message's mission time (see :class:`_Writer`);
    ``foxglove_channels``: add the Foxglove view's channels (:mod:`ground.foxglove`); ``live``:
    (host, port) to serve every channel over Foxglove's WebSocket protocol while recording;
    ``feed(topic, cls, payload, message, log_ns)``: called after each ICD message is recorded, in
    recording order (``message`` is the decoded ICD object, or only its JSON value without
    ``validate``; a feed with ``reads(topic)`` gets the topics it reads decoded, and None for the
    others where nothing else reads them), e.g. a :class:`ground.report.summary_feed.SummaryFeed`;
    ``on_closed(result)``: called once the file is finished, while the session still lets its last
    replies leave.
    """
    topics.check_run_id(run_id)
    out_path = os.fspath(out_path)
    until_end_of_run = until_end_of_run and bool(producers)
    items = _attachment_items(attachments)
    t0 = time.monotonic()
    ended_by = "stop"
    with tp.ProcessLifecycle(run_id, transport_cfg, stop_event=stop_event, handle_signals=handle_signals) as life:
        # a producer that resends after a restart (the simulator to a restarted FSW, a restarted FSW
        # its telemetry since its checkpoint) repeats sequence numbers: recorded once, counted
        sub = life.subscriber(("**",), decode=False, role="ground", capacity=capacity, dedupe=True, batch=RECEIVE_BATCH,
                              settle_s=settle_s if after else None)
        if after:
            earlier = segments.recorded(after)
            for topic, seqs in earlier.sequences.items():
                sub.preload(topic, seqs)
            sub.end_of_run.update(earlier.end_of_run)
        with McapRecorder(out_path, flush_interval_s=flush_interval_s, chunk_size=chunk_size) as rec:
            run_info = {
                "run_id": run_id,
                "schema_version": str(SCHEMA_VERSION),
                "started_unix_ns": str(time.time_ns()),
                "host": socket.gethostname(),
                "producers": ",".join(producers),
                "log_time": "mission" if mission_time else "receive",
            }
            run_info.update({str(k): v if isinstance(v, str) else json.dumps(v) for k, v in (metadata or {}).items()})
            rec.add_metadata("navbank.run", run_info)
            for name, data, media_type in items:
                rec.add_attachment(name, data, media_type)
            view = FoxgloveView() if foxglove_channels else None
            server = None if live is None else LiveView(live[0], live[1])
            tap = None if view is None and server is None else FoxgloveTap(rec, view, server)
            if server is not None and print_fn is not None:
                print_fn(f"live view: {server.url} (Foxglove: Open connection, Foxglove WebSocket)")
            write = _Writer(rec, validate, mission_time, tap, feed)
            if ready_event is not None:
                ready_event.set()
            finished_at: float | None = None
            next_check = 0.0
            while True:
                got = sub.recv(timeout=0.05)
                if got is not None:
                    write(got)
                else:
                    rec.tick()
                now = time.monotonic()
                stop_reason = life.stop_reason()
                if stop_reason is not None:
                    ended_by = stop_reason
                    break
                if max_duration_s is not None and now - t0 >= max_duration_s:
                    ended_by = "duration"
                    break
                if until_end_of_run and now >= next_check:
                    next_check = now + 0.05
                    if finished_at is None and sub.finished(producers):
                        finished_at = now
                    if finished_at is not None and (
                        all(sub.acknowledged.get(p) for p in producers) or now - finished_at >= linger_s
                    ):
                        ended_by = "end-of-run"
                        break
            for got in sub.drain_available():  # delivered before we stopped: keep it
                write(got)
            _record_announced_ends(sub, write, producers, after)
            if tap is not None:
                tap.close()
            finished = tuple(p for p in producers if sub.finished([p]))
            result = LogResult(
                path=out_path,
                ended_by=ended_by,
                elapsed_s=time.monotonic() - t0,
                counts=dict(rec.counts),
                unknown=write.unknown,
                invalid=write.invalid,
                gaps=_gaps(sub, producers),
                duplicates=dict(sub.duplicates),
                refused=dict(sub.refused),
                finished=finished,
            )
            rec.add_metadata(
                "navbank.logger",
                {"ended_by": ended_by, "elapsed_s": round(result.elapsed_s, 3), "counts": result.counts, "unknown": result.unknown,
                 "invalid": result.invalid, "gaps": result.gaps, "duplicates": result.duplicates,
                 "refused": result.refused,
                 "finished": list(finished)},
            )
        closed = time.monotonic()
        if on_closed is not None:
            on_closed(result)
        if ended_by == "end-of-run":
            # the last drain replies were just sent: they leave while on_closed works, and the
            # session waits out only what remains of the linger
            life.let_replies_leave(max(0.0, tp.REPLY_LINGER_S - (time.monotonic() - closed)))
    if print_fn is not None:
        print_fn(result.report())
    return result


"""Republish a recorded run over Zenoh under a new run id, with its original relative timing.

Order and pacing follow ``log_time`` — when the ground received each message — so a display or a
second logger sees the run as the first logger saw it (the interleaving of simulator and FSW
traffic included). ``publish_time`` is the message's simulated epoch and would compress days of
mission time into nothing or stretch it beyond use. Message *i* is sent at
``(log_time_i − log_time_0) / rate`` after the start; ``rate = 0`` sends as fast as the link
takes them. When the replay falls behind schedule it does not sleep until it has caught up.

Payloads are the recorded bytes, re-sent as-is through :meth:`Publisher.put_payload` on the
topic they were recorded on, with that topic's ICD encoding schema and a fresh per-publisher
sequence number. Payloads the first logger filed under ``/_invalid/<topic>`` are re-sent on
``<topic>`` (a second logger files them the same way); schema-less topics outside the ICD go out
as plain JSON. Payloads keep their original contents, so ``RunStatus.run_id`` inside them still
names the recorded run.

End of the replay
-----------------
The recorded end-of-run statuses of the simulator and the FSW are replayed like any message.
Then the replay publishes its own ``RunStatus(source="replay", state="end-of-run")`` on
``ground/status`` whose ``counts`` hold the number of messages it sent per topic (keys with
``/``) and ``messages`` in total, and — if consumers were named — drains into each of them
(:func:`fsw.transport.drain`), so a consumer can confirm it has taken every message.
A second logger therefore ends

* with ``--producers replay``: as soon as it has the replay's end-of-run status and everything
  announced in it, once the replay's drain query has been answered — the exact, complete way;
* with ``--producers sim,fsw`` (its default): when both replayed end-of-run statuses and the
  counts they announce have arrived, after its linger (2 s) because no live sim or FSW drains
  into it. Messages replayed after the FSW's end-of-run within that linger are still recorded.

With consumers named, each topic also gets a :class:`~fsw.transport.CreditWindow` per
consumer, so a fast replay never runs more than a window ahead of what a slow consumer has
taken (no loss at ``--fast`` however long the run).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import zenoh

import fsw.transport as tp
from fsw.interface import codec, topics
from fsw.interface.messages import RunStatus, Stamp
from ground.replay.recording import RecordingError, iter_raw, run_info

#: Topic of the replay's own end-of-run status (an ICD RunStatus topic, so subscribers track it).
REPLAY_STATUS_TOPIC = topics.GROUND_STATUS


class _JsonPublisher:
    """Publisher for a schema-less topic outside the ICD: same QoS and sequence attachment."""

    def __init__(self, session: zenoh.Session, run_id: str, topic: str, credit: Sequence[tp.CreditWindow] = ()):
        self.topic = topic
        self.count = 0
        self.credit = tuple(credit)
        self._pub = session.declare_publisher(
            topics.key(run_id, topic),
            encoding=zenoh.Encoding.APPLICATION_JSON,
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )

    def put_payload(self, payload: bytes) -> None:
        for window in self.credit:
            window.wait(self.count)
        self._pub.put(payload, attachment=tp.sequence_attachment(self.count))
        self.count += 1

    def close(self) -> None:
        self._pub.undeclare()


@dataclass
class ReplayResult:
    """What a republication sent."""

    run_id: str
    source_run_id: str
    counts: dict[str, int] = field(default_factory=dict)  # messages sent per topic (Zenoh key without run prefix)
    replayed: int = 0  # recorded messages sent (the counts less the replay's own end-of-run status)
    elapsed_s: float = 0.0
    recorded_span_s: float = 0.0  # log-time span of the recording
    drained: dict[str, bool] = field(default_factory=dict)  # consumer -> confirmed everything
    stopped: bool = False  # interrupted by stop_event before the end

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def report(self) -> str:
        lines = [f"navbank replay: {self.replayed} recorded messages of run {self.source_run_id or '?'} republished "
                 f"as run {self.run_id} in {self.elapsed_s:.1f} s (recorded span {self.recorded_span_s:.1f} s), "
                 f"then the replay's end-of-run status"
                 + (" -- STOPPED early" if self.stopped else "")]
        width = max((len(t) for t in self.counts), default=0)
        lines += [f"  {t:<{width}}  {n:>9}" for t, n in sorted(self.counts.items())]
        for c, ok in self.drained.items():
            lines.append(f"  consumer {c}: {'confirmed every message' if ok else 'did NOT confirm the end of the stream'}")
        return "\n".join(lines)


def _publisher_for(session: zenoh.Session, run_id: str, topic: str, credit: list[tp.CreditWindow]) -> tp.TopicPublisher:
    try:
        topics.type_of_topic(topic)
    except KeyError:
        return _JsonPublisher(session, run_id, topic, credit)
    return tp.Publisher(session, run_id, topic, credit=credit)


def _last_status(payload: bytes) -> RunStatus | None:
    try:
        return codec.from_json(RunStatus, payload)
    except codec.ICDError:
        return None


def _log_time_span_ns(path: str | os.PathLike) -> int:
    """log_time span of the ICD record (the derived channels excluded) from one pass over it."""
    lo = hi = None
    for msg in iter_raw(path):
        lo = msg.log_time_ns if lo is None else min(lo, msg.log_time_ns)
        hi = msg.log_time_ns if hi is None else max(hi, msg.log_time_ns)
    return 0 if lo is None or hi is None else hi - lo


def republish(
    path: str | os.PathLike,
    run_id: str,
    transport_cfg: tp.TransportConfig | None = None,
    *,
    rate: float = 1.0,
    consumers: Sequence[str] = (),
    consumer_timeout_s: float = 30.0,
    drain_timeout_s: float = 60.0,
    credit_window: int | None = None,
    stop_event: tp.StopFlag | None = None,
    progress: Callable[[str], None] | None = None,
    progress_every_s: float = 2.0,
    linger_s: float = 1.0,
) -> ReplayResult:
    """Republish the run recorded in ``path`` as run ``run_id`` (see the module documentation).

    ``rate`` scales the recorded timing (2: twice as fast; 0: no pacing). ``consumers`` are roles
    (e.g. ``ground``) waited for before the first message and drained into at the end.
    ``credit_window`` (default: 8192 shared among the topics) bounds how far each topic runs ahead
    of each consumer. Without consumers the session lingers ``linger_s`` before closing so the
    last messages in flight are delivered.
    """
    topics.check_run_id(run_id)
    if not rate >= 0.0 or rate == float("inf"):
        raise ValueError(f"rate must be a finite number >= 0, got {rate}")
    consumers = tuple(consumers)
    for c in consumers:
        if c not in tp.ROLES:
            raise ValueError(f"consumer {c!r}: expected one of {', '.join(tp.ROLES)}")
    info = run_info(path)
    total = sum(info.counts.values())
    if total == 0:
        raise RecordingError(f"{info.path}: no messages to replay")
    n_topics = len({t for t in info.counts}) + 1
    window = credit_window if credit_window is not None else max(64, 8192 // n_topics)
    result = ReplayResult(run_id=run_id, source_run_id=info.run_id)
    last_status: RunStatus | None = None
    t_wall0 = time.monotonic()
    # Signals keep their default action: an interrupted replay has nothing to finish (it only reads the recording).
    with tp.ProcessLifecycle(run_id, transport_cfg, stop_event=stop_event, handle_signals=False) as life:
        life.wait_for_consumers(consumers, timeout_s=consumer_timeout_s)

        def make_publisher(topic: str) -> tp.TopicPublisher:
            credit = [tp.CreditWindow(life.session, run_id, c, topic, window=window) for c in consumers]
            return _publisher_for(life.session, run_id, topic, credit)

        def publisher(topic: str) -> tp.TopicPublisher:
            return life.raw_publisher(topic, make_publisher)

        log0: int | None = None
        last_log = 0
        # A recording stamped with mission time spans days: its timing is played evenly over as
        # long as the logger recorded (rate 1), not in real mission time.
        span_ns = _log_time_span_ns(path) if info.mission_time else 0
        pace = info.wall_s / (span_ns / 1e9) if info.mission_time and info.wall_s and span_ns > 0 else 1.0
        done = 0
        next_progress = time.monotonic() + progress_every_s
        t_start = time.monotonic()
        for msg in iter_raw(path):
            if life.should_stop():
                result.stopped = True
                break
            if log0 is None:
                log0 = msg.log_time_ns
            last_log = max(last_log, msg.log_time_ns)
            if rate > 0.0:
                due = t_start + (msg.log_time_ns - log0) / 1e9 * pace / rate
                wait = due - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
            topic = msg.zenoh_topic
            publisher(topic).put_payload(msg.data)
            done += 1
            if topic.endswith("/status"):
                status = _last_status(msg.data)
                if status is not None:
                    last_status = status
            now = time.monotonic()
            if progress is not None and now >= next_progress:
                next_progress = now + progress_every_s
                span = (last_log - log0) / 1e9
                progress(f"replay: {done}/{total} messages ({100.0 * done / total:5.1f} %), "
                         f"recorded time +{span:.1f} s, wall {now - t_wall0:.1f} s")
        result.replayed = done
        result.recorded_span_s = 0.0 if log0 is None else (last_log - log0) / 1e9
        publisher(REPLAY_STATUS_TOPIC)  # declared before counting, so the counts name its topic
        counts = tp.end_of_run_counts(life.publishers.values(), messages=done)
        end = RunStatus(
            t_s=last_status.t_s if last_status is not None else 0.0,
            timestamp=last_status.timestamp if last_status is not None else Stamp.from_unix(time.time()),
            run_id=run_id,
            source="replay",
            state="error" if result.stopped else "end-of-run",
            counts=counts,
            message=f"replay of run {info.run_id or '?'} from {os.path.basename(info.path)} at rate {rate:g}",
        )
        life.announce_end(REPLAY_STATUS_TOPIC, end)
        result.counts = {t: p.count for t, p in life.publishers.items() if p.count}
        if progress is not None:
            progress(f"replay: {done}/{total} messages sent, end-of-run published")
        if consumers and not result.stopped:
            # a consumer that did not confirm is reported, not raised: the replay itself went through
            result.drained = life.confirm_end(end, consumers, timeout_s=drain_timeout_s, require_all=False)
        else:
            time.sleep(linger_s)
    result.elapsed_s = time.monotonic() - t_wall0
    return result

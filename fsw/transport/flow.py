"""Flow control between a producer and its consumers, all through the consumers' progress queryable.

* **Readiness.** :func:`wait_for_consumers` returns once every consumer answers its progress
  queryable; the queryable is declared after the consumer's subscriptions, so its subscriptions
  are up by then and the first message is not lost.
* **No loss when a consumer stalls** (BLOCK congestion control gives up after ~5 s and the link
  drops what is in flight): :class:`CreditWindow` keeps a producer at most ``window`` messages
  ahead of what a consumer has *taken* from its FIFO, as the consumer reports through its
  progress queryable.
* **No loss at close** (closing a session right after the last put loses the messages in
  flight): the end-of-stream handshake, :func:`drain`.

Progress queryable and end-of-stream handshake
----------------------------------------------
A consumer's :class:`~fsw.transport.pubsub.Subscriber` created with ``role=...`` answers queries
on ``navbank/<run>/<role>/progress`` with a :class:`~fsw.interface.messages.RunStatus` whose
``counts`` hold, per topic, the messages taken from its channels so far.

A producer ends a run by publishing its end-of-run ``RunStatus`` whose ``counts`` carry, for every
topic it published, the number of messages (keys containing ``/`` are topic counts; other keys are
free-form counters). It then calls :func:`drain`, which sends that same status as the payload of a
progress query to each consumer until each one replies ``counts["complete"] == 1`` — i.e. it has
taken at least the announced number of messages on every announced topic it subscribes to.
Only then may the producer close its session. The consumer remembers which producers it has
acknowledged (``Subscriber.acknowledged``), so it can itself close once every producer it waits
for has both ended (``Subscriber.finished``) and been told so; a short linger after the last
reply lets that reply leave before the session closes.
"""

from __future__ import annotations

import time
import typing
from collections.abc import Callable, Iterable
from typing import Any

import zenoh

from fsw.interface import codec, topics
from fsw.interface.messages import RunStatus
from fsw.transport import wire
from fsw.transport.session import TransportError

#: Progress counters of a restarted consumer: a number that differs for every start of the
#: process, and the count of the topic it takes again from (its checkpoint's position).
INCARNATION = "incarnation"
RESUMED_FROM = "resumed_from"


class ConsumerRestarted(Exception):
    """The credit consumer was restarted from a checkpoint: the producer must send its topic
    again from message number ``resume_from`` (with the original sequence numbers)."""

    def __init__(self, role: str, resume_from: int):
        super().__init__(f"{role} restarted; resend from message {resume_from}")
        self.role, self.resume_from = role, resume_from


#: Roles that may serve a progress queryable (the ``source`` values of RunStatus).
ROLES: tuple[str, ...] = typing.get_args(typing.get_type_hints(RunStatus)["source"])
PROGRESS = "progress"  # navbank/<run>/<role>/progress: consumer progress queryable
COMPLETE = "complete"  # counts key of a progress reply: 1 when the producer's stream is complete


def query_progress(
    session: zenoh.Session, run_id: str, role: str, status: RunStatus | None = None, timeout_s: float = 1.0
) -> RunStatus | None:
    """Ask consumer ``role`` for its progress (None if nobody answered in time)."""
    kwargs: dict[str, Any] = {"timeout": timeout_s}
    if status is not None:
        kwargs["payload"] = codec.to_json(status)
        kwargs["encoding"] = wire.encoding(RunStatus)
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
    The progress queryable is asked only when the window is used up, and the producer then waits
    until half of it is free again, so any consumer costs about one query per half window. ``stall_timeout_s`` (None: wait forever)
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
        self.incarnation: int | None = None  # of the consumer process last heard from
        self.restarts = 0
        self.refill = max(window // 2, 1)  # messages the consumer takes before the producer goes on
        self._heard: tuple[int, float] | None = None  # (taken, monotonic time) of the last progress
        self._rate: float | None = None  # the consumer's measured rate, messages per second

    def observe(self, reply: RunStatus) -> None:
        """Take note of a progress reply of the consumer. A consumer that says it was resumed
        (``resumed_from``) under an incarnation not seen before raises
        :class:`ConsumerRestarted`: its taken-count went back to its checkpoint's, and the
        window restarts from there (nothing is counted twice, nothing waits on the old count)."""
        incarnation = reply.counts.get(INCARNATION)
        if incarnation is None or incarnation == self.incarnation:
            return
        self.incarnation = incarnation
        resumed = reply.counts.get(RESUMED_FROM)
        if resumed is not None:
            self.restarts += 1
            self.taken = reply.counts.get(self.topic, resumed)
            self._heard = None  # its count went back: the rate is measured afresh
            raise ConsumerRestarted(self.role, resumed)

    def wait(self, published: int) -> None:
        """Return when message number ``published`` (0-based) may be sent.

        Once the window is used up the producer waits until the consumer has taken half of it
        (refill at half-window), not just one message: then it sends half a window without
        asking again, and a consumer slower than the producer costs about one query per half
        window instead of one per message. Between queries it sleeps for the time the consumer
        needs, at the rate its last two replies showed, to take what is missing."""
        if published - self.taken < self.window:
            return
        self.waits += 1
        target = published - self.refill  # taken-count that refills the window to half
        last_progress = time.monotonic()
        pause = self.poll_s
        self._sleep_until_taken(target)
        while True:
            self.queries += 1
            reply = query_progress(self.session, self.run_id, self.role, timeout_s=1.0)
            now = time.monotonic()
            progressed = False
            if reply is not None:
                self.observe(reply)
                taken = reply.counts.get(self.topic, 0)
                if taken > self.taken:
                    if self._heard is not None and now > self._heard[1] and taken > self._heard[0]:
                        self._rate = (taken - self._heard[0]) / (now - self._heard[1])
                    self._heard = (taken, now)
                    self.taken = taken
                    last_progress = now
                    pause = self.poll_s
                    progressed = True
                if self.taken >= target:
                    return
            if self.stall_timeout_s is not None and now - last_progress > self.stall_timeout_s:
                raise TransportError(
                    f"{self.role} took no {self.topic} message for {self.stall_timeout_s:g} s "
                    f"(taken {self.taken}, published {published})"
                )
            if not (progressed and self._sleep_until_taken(target)):
                time.sleep(pause)
                pause = min(pause * 2, 0.1)

    def _sleep_until_taken(self, target: int) -> bool:
        """Sleep for as long as the consumer, at its measured rate, needs to have taken ``target``
        messages (at most 0.5 s: it still has half a window queued then). False without a rate."""
        if self._rate is None or self._heard is None:
            return False
        predicted = self._heard[0] + self._rate * (time.monotonic() - self._heard[1])
        if predicted < target:
            time.sleep(min((target - predicted) / self._rate, 0.5))
        return True


def drain(
    session: zenoh.Session, run_id: str, status: RunStatus, consumers: Iterable[str], timeout_s: float = 30.0,
    *, on_reply: Callable[[str, RunStatus], None] | None = None,
) -> dict[str, bool]:
    """End-of-stream handshake: wait until every consumer confirms it has taken what ``status`` announces.

    ``status`` is the end-of-run RunStatus just published (counts per topic). Returns, per
    consumer, whether it confirmed within ``timeout_s``. Close the session only afterwards.
    ``on_reply(consumer, reply)`` sees every reply first (a producer that resends to a
    restarted consumer raises :class:`ConsumerRestarted` from it).
    """
    pending = list(consumers)
    done = {c: False for c in pending}
    deadline = time.monotonic() + timeout_s
    pause = 0.005
    while pending:
        for c in list(pending):
            reply = query_progress(session, run_id, c, status, timeout_s=1.0)
            if reply is not None and on_reply is not None:
                on_reply(c, reply)
            if reply is not None and reply.counts.get(COMPLETE) == 1:
                done[c] = True
                pending.remove(c)
        if not pending or time.monotonic() > deadline:
            break
        time.sleep(pause)
        pause = min(pause * 2, 0.1)
    return done

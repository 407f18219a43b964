"""ConsumerHold over real Zenoh on 127.0.0.1: a producer's puts wait while the consumer that was
there is gone, go on at once when it is back, and stop waiting after the timeout."""

from __future__ import annotations

import threading
import time

from fsw import transport as T
from fsw.interface import topics
from fsw.transport.pubsub import ConsumerHold, Publisher

RUN = "hold"


def _wait_until(predicate, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()


def test_hold_follows_the_consumer():
    session = T.open_session(T.TransportConfig())
    try:
        sentinel = Publisher(session, RUN, topics.SIM_STATUS)
        hold = ConsumerHold(sentinel, timeout_s=10.0, poll_s=0.005)
        hold.wait()
        assert not hold.seen and hold.holds == 0  # nobody was there yet: no waiting

        sub = session.declare_subscriber(sentinel.key)
        assert _wait_until(lambda: hold._matching is True)  # the listener saw the consumer arrive
        hold.wait()
        assert hold.seen and hold.holds == 0

        sub.undeclare()
        assert _wait_until(lambda: hold._matching is False)  # ... and leave
        back: list = []
        threading.Timer(0.3, lambda: back.append(session.declare_subscriber(sentinel.key))).start()
        t0 = time.monotonic()
        hold.wait()  # held until the consumer is back
        assert time.monotonic() - t0 >= 0.25
        assert hold.holds == 1 and hold.held_s >= 0.25 and not hold.gave_up
        assert _wait_until(lambda: hold._matching is True)
        hold.wait()
        assert hold.holds == 1  # matched again: no second hold
        back[0].undeclare()
    finally:
        session.close()


def test_hold_gives_up_after_its_timeout():
    session = T.open_session(T.TransportConfig())
    try:
        sentinel = Publisher(session, RUN, topics.SIM_STATUS)
        hold = ConsumerHold(sentinel, timeout_s=0.2, poll_s=0.01)
        sub = session.declare_subscriber(sentinel.key)
        assert _wait_until(lambda: hold._matching is True)
        hold.wait()
        sub.undeclare()
        assert _wait_until(lambda: hold._matching is False)
        t0 = time.monotonic()
        hold.wait()
        assert hold.gave_up and 0.15 <= time.monotonic() - t0 < 5.0
        t0 = time.monotonic()
        hold.wait()  # once given up, it never waits again: a consumer that does not return must not stop the run
        assert time.monotonic() - t0 < 0.1
    finally:
        session.close()

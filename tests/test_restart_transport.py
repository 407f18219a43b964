"""What a restart asks of the transport: a resumed consumer takes a topic again in order from its
checkpoint, a recorder keeps each (topic, sequence number) once, a producer sends again from
where the restarted consumer stands with the original numbers, and its credit window follows the
consumer's count back down without waiting on the old one."""

from __future__ import annotations

import time
from typing import Any, cast

import pytest

from fsw import transport as T
from fsw.interface import messages as m
from fsw.transport.pubsub import SeenSequences
from sim.resend import ResendingPublisher

RUN = "restart-test"


def _measurement(i: int) -> m.Measurement:
    return m.Measurement(seq=i, t_s=6.0e8 + 60.0 * i, timestamp=m.Stamp(sec=1_700_000_000 + i, nsec=0), kind="range",
                         source="DSS-14", value=(1.5e8 + i,), sigma=(0.002,))


def test_seen_sequences_tell_repeats_from_first_arrivals():
    seen = SeenSequences()
    assert [seen.add(s) for s in (0, 5, 3, 5, 0, 1000, 999, 1000)] == [True, True, True, False, False, True, True, False]
    assert 3 in seen and 4 not in seen and 10**7 not in seen and -1 not in seen
    assert seen.add(-1) and seen.add(-1)  # not a sequence number of ours: never called a repeat


def _take_all(sub: T.Subscriber, want: int, timeout_s: float = 5.0) -> list[T.Received]:
    got: list[T.Received] = []
    deadline = time.monotonic() + timeout_s
    while len(got) < want and time.monotonic() < deadline:
        r = sub.recv(timeout=0.05)
        if r is not None:
            got.append(r)
    time.sleep(0.1)
    return got + sub.drain_available()


def test_a_resumed_subscriber_takes_only_the_next_number_in_order():
    with T.open_session(T.TransportConfig()) as session:
        with T.Subscriber(session, RUN, "sim/measurements", resume={"sim/measurements": 5}) as sub, \
                T.Publisher(session, RUN, "sim/measurements") as pub:
            assert sub.counts() == {"sim/measurements": 5}  # what its checkpoint had taken
            pub.count = 8
            for i in (8, 9):  # sent before the producer heard of the restart: discarded
                pub.put(_measurement(i))
            pub.count = 5
            for i in range(5, 12):  # sent again from the checkpoint, then onwards
                pub.put(_measurement(i))
            got = _take_all(sub, 7)
    assert [r.pub_seq for r in got] == list(range(5, 12))
    assert sub.discarded == {"sim/measurements": 2}
    assert sub.counts() == {"sim/measurements": 12} and sub.gaps == {}


def test_a_deduplicating_subscriber_records_each_number_once_and_counts_repeats():
    with T.open_session(T.TransportConfig()) as session:
        with T.Subscriber(session, RUN, "**", decode=False, dedupe=True) as sub, \
                T.Publisher(session, RUN, "sim/measurements") as pub:
            for i in range(6):
                pub.put(_measurement(i))
            pub.count = 3  # a producer sending again after a restart, with the original numbers
            for i in range(3, 9):
                pub.put(_measurement(i))
            got = _take_all(sub, 9)
    assert [r.pub_seq for r in got] == list(range(9))
    assert sub.duplicates == {"sim/measurements": 3}
    assert sub.counts() == {"sim/measurements": 9} and not any(sub.gaps.values())


class _Pub:
    """The measurement publisher as the resender uses it: a count, and a put that may first hear
    (through its credit window) that the consumer restarted."""

    def __init__(self, restarts: dict[int, int]):
        self.count = 0
        self.put_seqs: list[int] = []
        self.restarts = dict(restarts)  # at put number -> resume from

    def put(self, msg: Any) -> None:
        n = len(self.put_seqs)
        if n in self.restarts:
            raise T.ConsumerRestarted("fsw", self.restarts.pop(n))
        assert msg.seq == self.count  # the original number goes with the original message
        self.put_seqs.append(self.count)
        self.count += 1


def test_the_resender_goes_back_to_the_checkpoint_with_the_original_numbers():
    pub = _Pub({6: 2})
    told: list[tuple[int, int]] = []
    res = ResendingPublisher(cast(T.Publisher, pub), on_rewind=lambda r: told.append((r.resume_from, r.sent)))
    for i in range(8):
        res.put(_measurement(i))
    assert pub.put_seqs == [0, 1, 2, 3, 4, 5, 2, 3, 4, 5, 6, 7]
    assert res.resent == 4 and [(r.resume_from, r.sent) for r in res.rewinds] == [(2, 6)] == told  # 0..5 had gone
    # a restart heard of at the end of the stream (the drain): everything after the checkpoint again
    res.rewind(T.ConsumerRestarted("fsw", 6))
    assert pub.put_seqs[-2:] == [6, 7] and pub.count == 8 and res.resent == 6


def test_a_resume_point_beyond_what_was_sent_sends_nothing_twice():
    pub = _Pub({})
    res = ResendingPublisher(cast(T.Publisher, pub))
    for i in range(3):
        res.put(_measurement(i))
    res.rewind(T.ConsumerRestarted("fsw", 10))
    assert pub.put_seqs == [0, 1, 2] and res.resent == 0 and pub.count == 3


class _Session:
    """Stands in for the session only to build a window; progress replies are fed to ``observe``."""


def _reply(counts: dict[str, int]) -> m.RunStatus:
    return m.RunStatus(t_s=0.0, timestamp=m.Stamp(sec=0, nsec=0), run_id=RUN, source="fsw", state="running",
                       counts=counts)


def test_the_credit_window_follows_a_restarted_consumer_back_down():
    window = T.CreditWindow(cast(Any, _Session()), RUN, "fsw", "sim/measurements", window=100)
    window.observe(_reply({"sim/measurements": 400, T.INCARNATION: 11}))  # the first FSW: nothing to do
    window.taken = 400
    with pytest.raises(T.ConsumerRestarted) as info:
        window.observe(_reply({"sim/measurements": 250, T.INCARNATION: 12, T.RESUMED_FROM: 250}))
    assert info.value.resume_from == 250 and window.taken == 250 and window.restarts == 1
    window.observe(_reply({"sim/measurements": 300, T.INCARNATION: 12, T.RESUMED_FROM: 250}))  # heard once only
    assert window.restarts == 1
    window.wait(349)  # resent from 250: within the window of the new count, no query needed
    assert window.queries == 0

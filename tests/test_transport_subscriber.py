"""Subscriber decoding, counters and the progress queryable, within one session (local delivery)."""

from __future__ import annotations

import pytest
import zenoh

from fsw import transport as T
from fsw.interface import codec, topics
from fsw.interface import messages as m

RUN = "sub-test"


def _meas(i: int) -> m.Measurement:
    return m.Measurement(seq=i, t_s=float(i), timestamp=m.Stamp(sec=1, nsec=i), kind="doppler", source="DSS-43",
                         value=(1e-3,), sigma=(1e-6,), count_time_s=60.0)


def _drain(sub: T.Subscriber) -> list[T.Received]:
    out = []
    while (got := sub.recv(timeout=0.3)) is not None:
        out.append(got)
    return out


def test_bad_payloads_are_counted_not_raised():
    with T.open_session(T.TransportConfig()) as s, T.Subscriber(s, RUN, ("sim/measurements",)) as sub:
        k = topics.key(RUN, "sim/measurements")
        good = codec.to_json(_meas(0))
        s.put(k, b"\x00garbage")
        s.put(k, good.replace(b'"seq":0', b'"seq":-1'))
        s.put(k, good, encoding=zenoh.Encoding.APPLICATION_JSON.with_schema("navbank.Truth/v1"))
        s.put(k, good)
        got = _drain(sub)
        assert [g.message for g in got] == [_meas(0)]
        assert sub.decode_errors == {"sim/measurements": 3}
        assert sub.received == {"sim/measurements": 4}
        assert "Truth" in sub.last_error


def test_raw_mode_returns_everything_and_counts_gaps():
    with T.open_session(T.TransportConfig()) as s, T.Subscriber(s, RUN, ("**",), decode=False) as sub:
        pub = T.Publisher(s, RUN, "sim/measurements")
        pub.put(_meas(0))
        pub.count += 2  # as if two messages had been lost on the way
        pub.put(_meas(3))
        s.put(topics.key(RUN, "custom/thing"), b'{"a":1}')
        got = _drain(sub)
        assert [g.topic for g in got] == ["sim/measurements", "sim/measurements", "custom/thing"]
        assert got[0].message is None and got[0].schema == "navbank.Measurement/v1" and got[0].pub_seq == 0
        assert got[2].schema == "" and got[2].pub_seq is None
        assert sub.gaps == {"sim/measurements": 2}
        assert sub.decode_errors == {}


def test_progress_reports_taken_counts_and_completeness():
    with T.open_session(T.TransportConfig()) as s, T.Subscriber(s, RUN, ("sim/measurements", "sim/status"), role="fsw") as sub:
        meas, status = T.Publisher(s, RUN, "sim/measurements"), T.Publisher(s, RUN, "sim/status")
        for i in range(5):
            meas.put(_meas(i))
        end = m.RunStatus(t_s=4.0, timestamp=m.Stamp(sec=1, nsec=0), run_id=RUN, source="sim", state="end-of-run",
                          counts={**T.end_of_run_counts([meas, status]), "sim/truth": 99})  # truth: not subscribed
        reply = T.query_progress(s, RUN, "fsw", end)
        assert reply.counts.get("sim/measurements", 0) == 0 and reply.counts[T.COMPLETE] == 0
        assert not sub.acknowledged
        status.put(end)
        got = _drain(sub)
        assert len(got) == 6 and sub.finished(["sim"]) and not sub.finished(["sim", "fsw"])
        reply = T.query_progress(s, RUN, "fsw", end)
        assert reply.counts == {"sim/measurements": 5, "sim/status": 1, T.COMPLETE: 1}
        assert sub.acknowledged == {"sim": True}
        assert sub.wait_acknowledged(["sim"], timeout_s=0.1, linger_s=0.0)
        assert not sub.wait_acknowledged(["sim", "replay"], timeout_s=0.1, linger_s=0.0)
        assert T.drain(s, RUN, end, ["fsw"], timeout_s=2) == {"fsw": True}
        assert T.drain(s, RUN, end, ["nobody"], timeout_s=0.3) == {"nobody": False}


def test_a_batch_is_handed_out_in_order_and_a_drain_returns_what_it_took_first():
    with T.open_session(T.TransportConfig()) as s, T.Subscriber(s, RUN, ("sim/measurements",), batch=4) as sub:
        pub = T.Publisher(s, RUN, "sim/measurements")
        for i in range(10):
            pub.put(_meas(i))
        s.put(topics.key(RUN, "sim/measurements"), b"\x00garbage")  # refused inside a batch, counted
        pub.count += 1
        pub.put(_meas(11))
        # a put within the session delivers to its own subscribers before it returns: all twelve wait
        first = sub.recv(timeout=2.0)
        assert first is not None and first.message == _meas(0)
        # the batch took three more than it handed out: they count as received already
        assert sub.counts()["sim/measurements"] == 4
        second = sub.recv(timeout=1.0)
        assert second is not None and second.message == _meas(1)
        rest = sub.drain_available()
        assert [g.message.seq for g in rest] == [2, 3, 4, 5, 6, 7, 8, 9, 11]
        assert sub.decode_errors == {"sim/measurements": 1} and sub.gaps == {"sim/measurements": 1}
        assert sub.recv(timeout=0.05) is None


def test_a_batch_must_take_at_least_one_sample():
    with T.open_session(T.TransportConfig()) as s:
        with pytest.raises(ValueError, match="batch"):
            T.Subscriber(s, RUN, ("sim/measurements",), batch=0)


def test_next_taken_hands_out_the_run_of_one_topic_a_batch_already_took():
    with T.open_session(T.TransportConfig()) as s, T.Subscriber(s, RUN, ("sim/measurements",), batch=8) as sub:
        pub = T.Publisher(s, RUN, "sim/measurements")
        assert sub.next_taken("sim/measurements") == []  # nothing taken: the channels are not read
        for i in range(10):
            pub.put(_meas(i))
        first = sub.recv(timeout=2.0)
        run = sub.next_taken("sim/measurements")
        # the batch took eight; the two left wait in the channel
        assert [g.message.seq for g in [first, *run]] == list(range(8))
        assert sub.next_taken("sim/measurements") == [] and sub.next_taken("sim/status") == []
        assert [g.message.seq for g in sub.drain_available()] == [8, 9]


def test_runs_taken_with_next_taken_lose_repeat_and_reorder_nothing():
    with T.open_session(T.TransportConfig()) as s, \
            T.Subscriber(s, RUN, ("sim/measurements", "sim/status"), batch=16) as sub:
        meas, status = T.Publisher(s, RUN, "sim/measurements"), T.Publisher(s, RUN, "sim/status")
        end = m.RunStatus(t_s=4.0, timestamp=m.Stamp(sec=1, nsec=0), run_id=RUN, source="sim", state="end-of-run",
                          counts={})
        for i in range(4):
            meas.put(_meas(i))
        status.put(end)
        got = [sub.recv(timeout=2.0)]
        while got[-1] is not None:
            got += sub.next_taken("sim/measurements") + [sub.recv(timeout=0.2)]
        got.pop()
        # two topics taken in turn: the runs stop at the status, which recv hands out in its place
        assert [g.message.seq for g in got if g.topic == "sim/measurements"] == [0, 1, 2, 3]
        assert [g.message for g in got if g.topic == "sim/status"] == [end]

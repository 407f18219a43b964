"""Subscriber decoding, counters and the progress queryable, within one session (local delivery)."""

from __future__ import annotations

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

"""How the ground logger reads the payloads it records without validating them
(``ground.logger._Writer``): each topic's payloads strictly decoded once where the summary feed
keeps them, only the timestamp read where nothing else reads them, the JSON value otherwise — and
the recording is the one the generic path (every payload's JSON value) makes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

import fsw.transport as tp
from fsw.interface import topics
from ground.foxglove.tap import FoxgloveTap
from ground.foxglove.view import FoxgloveView
from ground.logger import _parse_json, _stamp_only, _Writer
from ground.mcap_io.recorder import McapRecorder, publish_time_of
from ground.report.run_summary import reads_topic
from ground.report.summary_feed import SummaryFeed

GOLDEN = Path(__file__).parent / "golden" / "insight-4day.mcap"


def _golden_received(limit: int | None = None) -> list[tp.Received]:
    """The golden recording's ICD messages as the logger takes them from its subscription."""
    out: list[tp.Received] = []
    with open(GOLDEN, "rb") as f:
        for schema, channel, msg in make_reader(f).iter_messages(log_time_order=False):
            topic = channel.topic.lstrip("/")
            try:
                topics.type_of_topic(topic)
            except KeyError:
                continue  # the Foxglove view's channels
            out.append(tp.Received(topic, bytes(msg.data), msg.log_time, schema.name if schema else "", None,
                                   msg.sequence))
            if limit is not None and len(out) >= limit:
                break
    return out


def _measurement_payload(**timestamp: object) -> bytes:
    meas = next(r for r in _golden_received() if r.topic == topics.SIM_MEASUREMENTS)
    value = json.loads(meas.payload)
    value["timestamp"] = timestamp if timestamp else value["timestamp"]
    return json.dumps(value).encode()


class _JsonFeed:
    """A feed that does not say which topics it keeps: the writer hands it every payload's JSON value
    (the generic path, as before topics were read by need)."""

    def __init__(self) -> None:
        self.feed = SummaryFeed()

    def __call__(self, *args: object) -> None:
        self.feed(*args)  # type: ignore[arg-type]


def _record(path: Path, received: list[tp.Received], feed: object) -> _Writer:
    with McapRecorder(path, flush_interval_s=3600.0) as rec:
        write = _Writer(rec, False, True, FoxgloveTap(rec, FoxgloveView(), None), feed)  # type: ignore[arg-type]
        for got in received:
            write(got)
    return write


def _contents(path: Path) -> list[tuple[str, int, int, int, bytes]]:
    with open(path, "rb") as f:
        return [(c.topic, m.log_time, m.publish_time, m.sequence, bytes(m.data))
                for _, c, m in make_reader(f).iter_messages(log_time_order=False)]


@pytest.mark.parametrize("payload", [
    _measurement_payload(),
    _measurement_payload(sec=0, nsec=0),
    _measurement_payload(sec=12, nsec=999_999_999),
    _measurement_payload(sec=-1, nsec=0),  # out of range: no publish time
    _measurement_payload(sec=1, nsec=1_000_000_000),
    _measurement_payload(sec=1.5, nsec=0),  # not integers: no publish time
    _measurement_payload(sec=True, nsec=0),  # a JSON true is 1 to the JSON value's reading
    _measurement_payload(sec=1),  # nsec missing
    b'{"timestamp": null, "seq": 1}',
    b'{"seq": 1}',
    b'[1, 2, 3]',
    b'{"timestamp": {"sec": 5, "nsec": 6}, "value": [NaN]}',  # only json.loads takes NaN
    b'{"timestamp": {"sec": 5, "nsec": 6}, "timestamp": {"sec": 7, "nsec": 8}}',  # the last one counts
    b'{"timestamp": {"sec": 5, "nsec": 6, "extra": [1, {"a": 2}]}, "t_s": 1.0}',
])
def test_the_timestamp_alone_gives_the_publish_time_the_json_value_gives(payload):
    expected = publish_time_of(_parse_json(payload))
    got = _stamp_only(payload)
    # None: it cannot tell, and the writer reads the JSON value instead
    assert got is None or got == expected
    if expected is not None and b"NaN" not in payload and b"true" not in payload:
        assert got == expected  # the ordinary payloads are read on the cheap path


@pytest.mark.parametrize("payload", [b'{"timestamp": {"sec": 5, "nsec": 6}', b"not json", b""])
def test_a_payload_that_is_not_json_is_refused_on_either_path(payload):
    assert _stamp_only(payload) is None
    with pytest.raises(ValueError):
        _parse_json(payload)


def test_the_recording_and_the_summary_are_those_of_the_generic_path(tmp_path):
    received = _golden_received()
    # hostile payloads on each way of reading: a measurement that is not JSON, one that only
    # json.loads reads, one without a timestamp, a weights message that fails strict decoding
    weights = next(r for r in received if r.topic.startswith("fsw/weights/"))
    bad_weights = json.loads(weights.payload)
    bad_weights["weights"] = "not a list"
    extra = [
        tp.Received(topics.SIM_MEASUREMENTS, b"{broken", weights.receive_ns, "", None, 10**6),
        tp.Received(topics.SIM_MEASUREMENTS, _measurement_payload(sec=1.5, nsec=0), weights.receive_ns, "", None, 10**6 + 1),
        tp.Received(topics.SIM_MEASUREMENTS, b'{"seq": 1, "value": [NaN]}', weights.receive_ns, "", None, 10**6 + 2),
        tp.Received(weights.topic, json.dumps(bad_weights).encode(), weights.receive_ns, "", None, 10**6 + 3),
    ]
    fast_feed, generic_feed = SummaryFeed(), _JsonFeed()
    fast = _record(tmp_path / "fast.mcap", received, fast_feed)
    generic = _record(tmp_path / "generic.mcap", received, generic_feed)
    assert _contents(tmp_path / "fast.mcap") == _contents(tmp_path / "generic.mcap")
    assert fast_feed.spoiled is None and generic_feed.feed.spoiled is None
    context = {"scenario": "insight-4day", "seed": 1, "fault": None, "t0": 0.0}
    assert fast_feed.summarize(**context).to_json() == generic_feed.feed.summarize(**context).to_json()
    # each topic was read the cheapest way that serves its readers
    how = fast._reading
    assert how[topics.SIM_MEASUREMENTS] == "stamp"  # neither the summary nor the Foxglove view reads them
    assert all(how[t] == "typed" for t in how if reads_topic(topics.mcap_topic(t)))
    assert fast._read_as(topics.FSW_RESIDUALS) == "json"  # the Foxglove view plots them, the summary does not
    assert set(generic._reading.values()) == {"json"}

    fast = _record(tmp_path / "fast2.mcap", received + extra, SummaryFeed())
    generic = _record(tmp_path / "generic2.mcap", received + extra, _JsonFeed())
    assert _contents(tmp_path / "fast2.mcap") == _contents(tmp_path / "generic2.mcap")
    assert fast.invalid == generic.invalid == {topics.SIM_MEASUREMENTS: 1}  # only the broken one
    # the weights that fail strict decoding are recorded all the same, and spoil the summary feed
    assert fast.feed.spoiled and generic.feed.feed.spoiled  # type: ignore[union-attr]


def test_the_summary_feed_is_handed_the_messages_decoded(tmp_path):
    class Kinds(SummaryFeed):
        __slots__ = ("handed",)

        def __init__(self) -> None:
            super().__init__()
            self.handed: set[str] = set()

        def __call__(self, topic, cls, payload, message, log_ns):  # type: ignore[no-untyped-def]
            if self.reads(topic):
                self.handed.add("decoded" if isinstance(message, cls) else type(message).__name__)
            super().__call__(topic, cls, payload, message, log_ns)

    feed = Kinds()
    _record(tmp_path / "run.mcap", _golden_received(limit=3000), feed)
    assert feed.handed == {"decoded"} and len(feed) > 100

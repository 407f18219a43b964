"""The summary fed message by message as the logger records (``ground.report.summary_feed``)
against the summary of the same recording read back (``ground.mcap_io.reader``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader

from fsw.interface import topics
from ground.logger import _parse_json
from ground.mcap_io.reader import read_messages, summary as mcap_counts
from ground.report.run_summary import reads_topic, summarize
from ground.report.summary_feed import SummaryFeed

GOLDEN = Path(__file__).parent / "golden"
CONTEXT = {"scenario": "insight-4day", "seed": 1, "fault": None, "t0": 0.0}


def _recorded(path: Path) -> list[tuple[str, type, bytes, int]]:
    """Every ICD message of a recording in file order, as the logger wrote them."""
    out = []
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages(log_time_order=False):
            topic = channel.topic.lstrip("/")
            try:
                cls = topics.type_of_topic(topic)
            except KeyError:
                continue  # the Foxglove view's channels
            out.append((topic, cls, bytes(message.data), message.log_time))
    return out


def _read_back(path: Path, **context) -> dict:
    wanted = [t for t in mcap_counts(path) if reads_topic(t)]
    messages = [(r.topic, r.message) for r in read_messages(path, topics=wanted, sort_in_memory=True)]
    return summarize(messages, **context).to_json()


@pytest.mark.parametrize("name", ["insight-4day", "thrusters-4day"])
def test_the_fed_summary_is_the_summary_of_the_recording(name):
    path = GOLDEN / f"{name}.mcap"
    feed = SummaryFeed()
    recorded = _recorded(path)
    for topic, cls, payload, log_ns in recorded:
        feed(topic, cls, payload, _parse_json(payload), log_ns)  # the logger's JSON value, not validated
    assert feed.spoiled is None
    kept = [r for r in recorded if reads_topic(topics.mcap_topic(r[0]))]
    assert len(feed) == len(kept) > 100
    assert len(kept) < len(recorded)  # the measurements are not kept
    context = dict(CONTEXT, scenario=name)
    assert feed.summarize(**context).to_json() == _read_back(path, **context)


def test_messages_come_out_in_log_time_order_ties_in_recording_order():
    from fsw.interface import codec
    from fsw.interface.messages import FaultEvent, Stamp

    def event(fault_id: str, t: float) -> FaultEvent:
        return FaultEvent(timestamp=Stamp.from_unix(1.7e9 + t), t_s=t, fault_id=fault_id, fault_type="optical-bias",
                          event="start", fault_class="optical-measurement")

    feed = SummaryFeed()
    for fault_id, log_ns in (("late", 30), ("first", 10), ("second", 10), ("middle", 20)):
        msg = event(fault_id, float(log_ns))
        feed(topics.SIM_FAULTS, FaultEvent, codec.to_json(msg), msg, log_ns)
    assert [m.fault_id for _, m in feed.messages()] == ["first", "second", "middle", "late"]
    assert {t for t, _ in feed.messages()} == {"/" + topics.SIM_FAULTS}


def test_a_message_that_fails_strict_decoding_spoils_the_feed():
    recorded = _recorded(GOLDEN / "insight-4day.mcap")
    feed = SummaryFeed()
    topic, cls, payload, log_ns = next(r for r in recorded if r[0] == topics.FSW_BUDGET)
    bad = payload.replace(b'"utilisation":', b'"utilisation":"high","was":', 1)
    assert bad != payload
    feed(topic, cls, bad, _parse_json(bad), log_ns)
    assert feed.spoiled is not None and feed.spoiled.startswith("/fsw/budget")
    for topic, cls, payload, log_ns in recorded:  # nothing after it makes the feed whole again
        feed(topic, cls, payload, None, log_ns)
    assert len(feed) == 0
    with pytest.raises(ValueError, match="fails strict decoding"):
        feed.messages()

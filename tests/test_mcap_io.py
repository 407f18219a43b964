"""MCAP recording and reading: schemas, times, metadata, truncated files, recovery."""

from __future__ import annotations

import json

import jsonschema
import pytest
from mcap.reader import make_reader
from mcap.records import Metadata
from mcap.writer import IndexType, Writer

from fsw.interface import codec
from fsw.interface import messages as m
from ground.mcap_io.reader import iter_records
from ground.mcap_io import (
    INVALID_PREFIX,
    McapReadError,
    McapRecorder,
    is_complete,
    read_attachments,
    read_messages,
    read_metadata,
    recover,
    summary,
)

T0 = 1_700_000_000


def _meas(i: int) -> m.Measurement:
    return m.Measurement(seq=i, t_s=6e8 + i, timestamp=m.Stamp(sec=T0 + i, nsec=123), kind="optical", source="phobos",
                         value=(512.0 + i, 256.0), sigma=(0.2, 0.3), attitude_q=(1.0, 0.0, 0.0, 0.0))


def _weights(i: int) -> m.FilterWeights:
    return m.FilterWeights(t_s=6e8 + i, timestamp=m.Stamp(sec=T0 + i, nsec=0), network="chi2", batch=i,
                           filters=("radio", "optical", "fused"), weights=(0.9, 0.06, 0.04))


def _record(path, n=300, flush_interval_s=0.5, chunk_size=64 * 1024):
    rec = McapRecorder(path, flush_interval_s=flush_interval_s, chunk_size=chunk_size)
    rec.add_metadata("navbank.run", {"run_id": "r1", "scenario": "insight-approach"})
    rec.add_attachment("scenario.yaml", b"name: insight\n", "application/yaml")
    for i in range(n):
        rec.write_message("sim/measurements", _meas(i), log_time_ns=(T0 + 10) * 10**9 + i)
        if i % 10 == 0:
            rec.write_message("fsw/weights/chi2", _weights(i), log_time_ns=(T0 + 10) * 10**9 + i)
    rec.write("custom/debug", b'{"note":"x"}', log_time_ns=(T0 + 20) * 10**9)
    rec.write(INVALID_PREFIX + "/sim/measurements", b"\x00\x01", log_time_ns=(T0 + 20) * 10**9 + 1)
    return rec


def test_round_trip_channels_schemas_and_times(tmp_path):
    path = tmp_path / "run.mcap"
    _record(path).close()
    assert is_complete(path)
    msgs = list(read_messages(path))
    meas = [x for x in msgs if x.topic == "/sim/measurements"]
    assert [x.message for x in meas] == [_meas(i) for i in range(300)]
    assert meas[5].log_time_ns == (T0 + 10) * 10**9 + 5
    assert meas[5].publish_time_ns == (T0 + 5) * 10**9 + 123
    assert summary(path) == {"/_invalid/sim/measurements": 1, "/custom/debug": 1, "/fsw/weights/chi2": 30, "/sim/measurements": 300}
    assert [x.message for x in read_messages(path, topics="custom/debug")] == [{"note": "x"}]
    assert [x.message for x in read_messages(path, topics=["/_invalid/sim/measurements"])] == [b"\x00\x01"]
    assert read_metadata(path)["navbank.run"] == {"run_id": "r1", "scenario": "insight-approach"}
    assert read_attachments(path)["scenario.yaml"] == ("application/yaml", b"name: insight\n")

    # Each channel declares what Foxglove needs; each message validates against its schema.
    with open(path, "rb") as f:
        reader = make_reader(f)
        summ = reader.get_summary()
        by_topic = {c.topic: c for c in summ.channels.values()}
        assert by_topic["/sim/measurements"].message_encoding == "json"
        sch = summ.schemas[by_topic["/sim/measurements"].schema_id]
        assert (sch.name, sch.encoding) == ("navbank.Measurement/v1", "jsonschema")
        assert sch.data == codec.schema_bytes(m.Measurement)
        assert by_topic["/custom/debug"].schema_id == 0
        n, validators = 0, {}
        for schema, channel, msg in reader.iter_messages():
            if schema is not None:
                if schema.id not in validators:
                    validators[schema.id] = jsonschema.Draft202012Validator(json.loads(schema.data))
                validators[schema.id].validate(json.loads(msg.data))
                n += 1
        assert n == 330


def test_every_truncation_point_reads_a_prefix_and_recovers(tmp_path):
    path = tmp_path / "run.mcap"
    rec = _record(path, n=600, chunk_size=2048)
    rec.flush()
    data = path.read_bytes()  # flushed but never finished: what a SIGKILL leaves behind
    rec.close()
    full = [x.message for x in read_messages(path, topics="/sim/measurements")]
    assert len(full) == 600
    seen = []
    for cut in [*range(len(data) // 7, len(data), len(data) // 11), len(data) - 1, len(data)]:
        part = tmp_path / "part.mcap"
        part.write_bytes(data[:cut])
        assert not is_complete(part)
        got = [x.message for x in read_messages(part, topics="/sim/measurements")]
        assert got == full[: len(got)]  # an exact prefix, never garbage
        seen.append(len(got))
        fixed = tmp_path / "fixed.mcap"
        res = recover(part, fixed)
        assert is_complete(fixed) and not res.complete
        assert [x.message for x in read_messages(fixed, topics="/sim/measurements")] == got
        assert summary(fixed).get("/sim/measurements", 0) == len(got)
    assert seen == sorted(seen) and seen[-1] == 600 and seen[0] < 600
    assert read_metadata(tmp_path / "fixed.mcap")["navbank.run"]["run_id"] == "r1"


def test_recover_of_a_complete_file_is_identical_in_content(tmp_path):
    path = tmp_path / "run.mcap"
    _record(path).close()
    res = recover(path, tmp_path / "copy.mcap")
    assert res.complete and res.messages == 332
    assert list(read_messages(path)) == list(read_messages(tmp_path / "copy.mcap"))
    with pytest.raises(ValueError):
        recover(path, path)


def test_time_based_flush_makes_recent_messages_durable(tmp_path):
    path = tmp_path / "run.mcap"
    rec = McapRecorder(path, flush_interval_s=0.05)
    rec.write_message("sim/measurements", _meas(0), log_time_ns=1)
    assert summary(path) == {}  # still in the open chunk
    import time

    time.sleep(0.06)
    rec.tick()
    assert summary(path) == {"/sim/measurements": 1}
    rec.close()


def test_not_mcap_and_schema_mismatch_are_typed_errors(tmp_path):
    bogus = tmp_path / "x.mcap"
    bogus.write_bytes(b"hello world, not mcap")
    with pytest.raises(McapReadError):
        list(read_messages(bogus))
    path = tmp_path / "bad.mcap"
    with McapRecorder(path) as rec:
        rec.write("sim/measurements", b'{"seq":"nope"}', log_time_ns=5)
    with pytest.raises(McapReadError, match="seq"):
        list(read_messages(path))
    assert [x.message for x in read_messages(path, strict=False)] == [b'{"seq":"nope"}']
    with McapRecorder(tmp_path / "c.mcap") as rec, pytest.raises(TypeError):
        rec.write_message("sim/measurements", _weights(0))


@pytest.mark.parametrize("index_types", [IndexType.ALL, IndexType.CHUNK])  # CHUNK: no metadata indexes
def test_metadata_through_the_summary_equals_streaming(tmp_path, index_types):
    path = tmp_path / "m.mcap"
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=1024, index_types=index_types)
        w.start()
        ch = w.register_channel(topic="/x", message_encoding="json", schema_id=0)
        for i in range(200):
            w.add_message(channel_id=ch, log_time=i, publish_time=i, data=b"{}")
            if i % 70 == 0:  # the same name again later: the last one wins
                w.add_metadata(f"name-{i % 140}", {"i": str(i)})
        w.finish()
    streamed: dict[str, dict[str, str]] = {}
    for r in iter_records(path):
        if isinstance(r, Metadata):
            streamed[r.name] = dict(r.metadata)
    assert read_metadata(path) == streamed == {"name-0": {"i": "140"}, "name-70": {"i": "70"}}

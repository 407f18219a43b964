"""The chunk-at-a-time message reader against mcap's own seeking reader, on files written by
mcap's writer with every compression, with and without message indexes, and damaged."""

from __future__ import annotations

import random

import pytest
from mcap.reader import SeekingReader
from mcap.writer import CompressionType, IndexType, Writer

from ground.mcap_io.chunks import ChunkError, read_chunked
from ground.mcap_io.reader import iter_channel_messages

TOPICS = ("/fsw/weights/chi2", "/fsw/budget", "/sim/truth")


def _write(path, compression: CompressionType, index_types: IndexType = IndexType.ALL, n: int = 3000) -> None:
    rng = random.Random(7)
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=4096, compression=compression, index_types=index_types)
        w.start()
        schema = w.register_schema(name="s", encoding="jsonschema", data=b"{}")
        ids = [w.register_channel(topic=t, message_encoding="json", schema_id=schema) for t in TOPICS]
        w.register_channel(topic="/raw", message_encoding="", schema_id=0)  # a channel without schema
        t = 1_700_000_000_000_000_000
        for i in range(n):
            t += rng.randrange(0, 3) * 1000  # equal log times too: ties keep file order
            payload = b'{"i": %d, "pad": "%s"}' % (i, b"x" * rng.randrange(0, 200))
            w.add_message(channel_id=rng.choice(ids), log_time=t, publish_time=t - i, data=payload, sequence=i)
        w.finish()


def _library(path, topics):
    with open(path, "rb") as f:
        return list(SeekingReader(f, validate_crcs=True).iter_messages(topics=topics, log_time_order=False))


@pytest.mark.parametrize("compression", [CompressionType.ZSTD, CompressionType.LZ4, CompressionType.NONE])
@pytest.mark.parametrize("index_types", [IndexType.ALL, IndexType.CHUNK])  # CHUNK: no message indexes
def test_the_same_messages_as_the_seeking_reader(tmp_path, compression, index_types):
    path = tmp_path / "f.mcap"
    _write(path, compression, index_types)
    for topics in (None, {"/fsw/budget"}, {"/fsw/weights/chi2", "/sim/truth"}, set()):
        expected = _library(path, topics)
        with open(path, "rb") as f:
            reader = SeekingReader(f)
            summ = reader.get_summary()
            ids = None if topics is None else {c for c, ch in summ.channels.items() if ch.topic in topics}
            got = read_chunked(f, summ, ids)
        assert got == [m for _, _, m in expected]
        assert len(got) == (3000 if topics is None else len(expected))


@pytest.mark.parametrize("index_types", [IndexType.ALL, IndexType.NONE])  # NONE: mcap's reader reads it
def test_iter_channel_messages_sorted_in_memory_equals_log_time_order(tmp_path, index_types):
    path = tmp_path / "f.mcap"
    _write(path, CompressionType.ZSTD, index_types)
    with open(path, "rb") as f:
        expected = list(SeekingReader(f).iter_messages(topics=["/fsw/budget", "/sim/truth"], log_time_order=True))
    got = list(iter_channel_messages(path, {"/fsw/budget", "/sim/truth"}, sort_in_memory=True))
    assert got == expected and len(got) > 1000


def test_a_damaged_chunk_is_an_error_not_wrong_data(tmp_path):
    path = tmp_path / "f.mcap"
    _write(path, CompressionType.NONE)
    with open(path, "rb") as f:
        summ = SeekingReader(f).get_summary()
    index = summ.chunk_indexes[3]
    raw = bytearray(path.read_bytes())
    raw[index.chunk_start_offset + index.chunk_length - 5] ^= 0xFF  # inside the last record's data
    path.write_bytes(bytes(raw))
    with open(path, "rb") as f:
        with pytest.raises(ChunkError, match="CRC"):
            read_chunked(f, summ, None)

"""The message records of a complete, chunked MCAP file, parsed a chunk at a time.

mcap's readers parse every record of a chunk field by field through a Python stream object
(~17 small reads per message): reading back a 45-day run's ~68k telemetry messages took 1.8 s of
the 2 s the end-of-run summary spent in the file. A Message record inside a decompressed chunk
is fixed-layout (MCAP specification, "Message": opcode 0x05, u64 record length, u16 channel id,
u32 sequence, u64 log time, u64 publish time, then the data to the record's end), so one
``struct.unpack_from`` per record reads it; everything else in a chunk is skipped by its length.

Only the chunks of the file's summary (its chunk indexes) are read, as mcap's seeking reader
does; a chunk's CRC, when the writer set one, is checked as that reader checks it.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Collection
from typing import BinaryIO

from mcap.exceptions import McapError
from mcap.records import Message
from mcap.summary import Summary

_RECORD = struct.Struct("<BQ")  # opcode, record length
_MESSAGE = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_CHUNK = struct.Struct("<QQQII")  # start and end time, uncompressed size and CRC, compression length
_U64 = struct.Struct("<Q")
_OP_CHUNK = 0x06
_OP_MESSAGE = 0x05


class ChunkError(McapError):
    """A chunk that is not what its index says, or whose content fails its CRC."""


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        import zstandard

        return zstandard.decompress(data, size)
    if compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        return lz4.frame.decompress(data)
    raise ChunkError(f"unsupported chunk compression {compression!r}")


def chunk_records(stream: BinaryIO, offset: int, length: int) -> bytes:
    """The decompressed records of the chunk record at ``offset`` (``length`` bytes in all)."""
    stream.seek(offset)
    raw = stream.read(length)
    if len(raw) != length:
        raise ChunkError(f"chunk at {offset}: the file ends inside it")
    opcode, _ = _RECORD.unpack_from(raw, 0)
    if opcode != _OP_CHUNK:
        raise ChunkError(f"chunk at {offset}: record opcode {opcode:#04x}")
    pos = _RECORD.size
    _, _, size, crc, n = _CHUNK.unpack_from(raw, pos)
    pos += _CHUNK.size
    compression = raw[pos:pos + n].decode()
    pos += n
    (data_length,) = _U64.unpack_from(raw, pos)
    pos += _U64.size
    data = _decompress(compression, raw[pos:pos + data_length], size)
    if len(data) != size:
        raise ChunkError(f"chunk at {offset}: {len(data)} bytes decompressed, {size} declared")
    if crc != 0 and zlib.crc32(data) != crc:
        raise ChunkError(f"chunk at {offset}: CRC mismatch")
    return data


def messages_in(data: bytes, channels: Collection[int] | None) -> list[Message]:
    """The Message records of decompressed chunk ``data`` on ``channels`` (all if None), in order."""
    out: list[Message] = []
    record, message, end = _RECORD.unpack_from, _MESSAGE.unpack_from, len(data)
    pos = 0
    while pos < end:
        opcode, length = record(data, pos)
        body = pos + 9
        pos = body + length
        if pos > end:
            raise ChunkError("a record runs past the end of its chunk")
        if opcode != _OP_MESSAGE:
            continue
        channel, sequence, log_time, publish_time = message(data, body)
        if channels is None or channel in channels:
            out.append(Message(channel_id=channel, sequence=sequence, log_time=log_time,
                               publish_time=publish_time, data=data[body + 22:pos]))
    return out


def read_chunked(stream: BinaryIO, summary: Summary, channels: Collection[int] | None) -> list[Message]:
    """Every message on ``channels`` (all if None) in the chunks ``summary`` indexes, chunk by chunk
    in the summary's order, each chunk's records in order: what mcap's seeking reader yields with
    ``log_time_order=False``."""
    out: list[Message] = []
    for index in summary.chunk_indexes:
        # without message indexes a chunk's channels are known only by reading it
        offsets = index.message_index_offsets
        if channels is not None and offsets and not any(c in channels for c in offsets):
            continue
        out.extend(messages_in(chunk_records(stream, index.chunk_start_offset, index.chunk_length), channels))
    return out


__all__ = ["ChunkError", "chunk_records", "messages_in", "read_chunked"]

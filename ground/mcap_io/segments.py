"""A recording in segments: what a restarted logger needs of the earlier ones, and their merge.

When the logger dies, ``navbank run`` starts a new one on a new segment file. The new logger
first reads the earlier segments (complete or cut short, :func:`recorded`): which publisher
sequence numbers of each topic are already recorded — so it records only the rest — and the
producers' end-of-run statuses already recorded. At the end of the run the segments are merged
into one complete MCAP file (:func:`merge`), readable by any MCAP reader; each segment's span
says when nothing was being recorded.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from mcap.records import Attachment, Channel, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from fsw.interface import codec
from fsw.interface.messages import RunStatus
from ground.foxglove.records import is_derived
from ground.mcap_io.reader import StreamResult, iter_records
from ground.mcap_io.recorder import INVALID_PREFIX


@dataclass
class Recorded:
    """What earlier segments hold: sequence numbers per topic (ICD topic names, no leading '/')
    and the producers' end-of-run statuses."""

    sequences: dict[str, list[int]] = field(default_factory=dict)
    end_of_run: dict[str, RunStatus] = field(default_factory=dict)


def recorded(paths: Iterable[str | os.PathLike[str]]) -> Recorded:
    """Read the earlier segments ``paths`` (each up to its last complete chunk)."""
    out = Recorded()
    for path in paths:
        channels: dict[int, str] = {}
        for record in iter_records(path):
            if isinstance(record, Channel):
                channels[record.id] = record.topic
            elif isinstance(record, Message):
                topic = channels.get(record.channel_id)
                if topic is None or topic.startswith(INVALID_PREFIX) or is_derived(topic):
                    continue  # what did not decode was never counted as taken; derived channels never were on the bus
                name = topic.lstrip("/")
                out.sequences.setdefault(name, []).append(record.sequence)
                if name.endswith("/status"):
                    try:
                        status = codec.from_json(RunStatus, record.data)
                    except codec.ICDError:
                        continue
                    if status.state == "end-of-run":
                        out.end_of_run[status.source] = status
    return out


@dataclass(frozen=True)
class Segment:
    """One segment as merged."""

    path: str
    messages: int
    complete: bool  # its logger finished it (footer present)
    first_log_ns: int | None  # receive time of its first and last message
    last_log_ns: int | None
    stopped: str  # why reading stopped early ('' if it did not)


def merge(segments: Sequence[str | os.PathLike[str]], dst: str | os.PathLike[str], *,
          chunk_size: int = 64 * 1024) -> list[Segment]:
    """Write every message of ``segments`` (in order) into one complete MCAP file ``dst``.

    Channels are matched by topic, schema and encoding; metadata records are all kept (a
    reader taking the last of a name gets the last logger's); attachments once per name. The
    segments do not repeat each other (each logger recorded only what the earlier ones had not)."""
    dst = os.fspath(dst)
    out_segments: list[Segment] = []
    schema_key_id: dict[tuple[str, str, bytes], int] = {}
    channel_key_id: dict[tuple[str, str, int], int] = {}
    attached: set[str] = set()
    with open(dst, "wb") as f:
        writer = Writer(f, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        writer.start(profile="", library="navbank")
        for path in segments:
            result = StreamResult()
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            n, first, last = 0, None, None
            for record in iter_records(path, result):
                if isinstance(record, Schema):
                    key = (record.name, record.encoding, bytes(record.data))
                    if key not in schema_key_id:
                        schema_key_id[key] = writer.register_schema(record.name, record.encoding, record.data)
                    schemas[record.id] = schema_key_id[key]
                elif isinstance(record, Channel):
                    sid = schemas.get(record.schema_id, 0) if record.schema_id else 0
                    ckey = (record.topic, record.message_encoding, sid)
                    if ckey not in channel_key_id:
                        channel_key_id[ckey] = writer.register_channel(record.topic, record.message_encoding, sid,
                                                                       dict(record.metadata))
                    channels[record.id] = channel_key_id[ckey]
                elif isinstance(record, Message):
                    cid = channels.get(record.channel_id)
                    if cid is None:
                        continue
                    writer.add_message(cid, log_time=record.log_time, data=record.data,
                                       publish_time=record.publish_time, sequence=record.sequence)
                    n += 1
                    first = record.log_time if first is None else min(first, record.log_time)
                    last = record.log_time if last is None else max(last, record.log_time)
                elif isinstance(record, Metadata):
                    writer.add_metadata(record.name, dict(record.metadata))
                elif isinstance(record, Attachment) and record.name not in attached:
                    attached.add(record.name)
                    writer.add_attachment(record.create_time, record.log_time, record.name, record.media_type,
                                          record.data)
            out_segments.append(Segment(os.fspath(path), n, result.complete, first, last, result.stopped))
        writer.add_metadata("navbank.segments", {
            f"{i}": f"{os.path.basename(s.path)}: {s.messages} messages" + ("" if s.complete else " (cut short)")
            for i, s in enumerate(out_segments)})
        writer.finish()
        f.flush()
        os.fsync(f.fileno())
    return out_segments

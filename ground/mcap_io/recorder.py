"""Writing a run to MCAP the way Foxglove and our reader expect it.

One channel per topic (``/sim/measurements``, ``/fsw/weights/chi2``, ...), message encoding
``json``, schema encoding ``jsonschema`` with the ICD schema named ``navbank.<Type>/v1``.
``publish_time`` is the message's own ``timestamp`` and ``log_time`` whatever the caller passes
(the ground logger: the same mission time by default, or the receive time), both ns since the
Unix epoch. Channels outside the ICD (Foxglove's well-known types) go through
:meth:`McapRecorder.write_foreign`. Chunks are small (64 KiB, zstd) and closed at least every
``flush_interval_s`` so that a recorder killed without warning leaves everything but its last
second readable by :func:`ground.mcap_io.reader.read_messages`.
"""

from __future__ import annotations

import json
import os
import time
from typing import Any

from mcap.writer import CompressionType, Writer

from fsw.interface import codec, topics

#: Channel prefix for payloads that arrived on an ICD topic but do not decode (kept, never lost).
INVALID_PREFIX = "/_invalid"
#: Channel prefix for statuses whose authentication failed (forged): recorded apart, so nothing
#: that reads the run's own channels takes them for the producer's.
REFUSED_PREFIX = "/_refused"
RAW_ENCODING = "application/octet-stream"
PROFILE = ""  # no well-known MCAP profile fits JSON + JSON Schema; Foxglove reads it as is


def publish_time_of(message: Any) -> int | None:
    """ns since the Unix epoch from a message's ``timestamp`` (ICD object or parsed JSON dict)."""
    stamp = getattr(message, "timestamp", None)
    if stamp is not None:
        return stamp.to_ns()
    if isinstance(message, dict):
        ts = message.get("timestamp")
        if isinstance(ts, dict):
            sec, nsec = ts.get("sec"), ts.get("nsec")
            if isinstance(sec, int) and isinstance(nsec, int) and sec >= 0 and 0 <= nsec < 1_000_000_000:
                return sec * 1_000_000_000 + nsec
    return None


class McapRecorder:
    """An MCAP file being written; :meth:`close` finishes it (summary, footer).

    ``write`` takes a topic as the Zenoh key without the run prefix (``sim/measurements``) or as
    an MCAP topic (``/sim/measurements``). Topics outside the ICD get a schema-less ``json``
    channel; payloads for :attr:`INVALID_PREFIX` channels are stored as raw bytes.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        *,
        chunk_size: int = 64 * 1024,
        flush_interval_s: float = 0.5,
        compression: str = "zstd",
    ):
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}
        if compression not in comp:
            raise ValueError(f"compression {compression!r}: expected one of {', '.join(comp)}")
        if flush_interval_s <= 0:
            raise ValueError("flush_interval_s must be > 0")
        self.path = os.fspath(path)
        self.flush_interval_s = flush_interval_s
        self._file = open(self.path, "wb")
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=comp[compression])
        self._writer.start(profile=PROFILE, library="navbank")
        self._file.flush()
        self._schemas: dict[type, int] = {}
        self._foreign_schemas: dict[tuple[str, str], int] = {}
        self._channels: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self._last_flush = time.monotonic()
        self._dirty = False
        self.closed = False

    # -- channels ----------------------------------------------------------------------------
    def channel_for(self, topic: str) -> int:
        """Channel id of ``topic``, registering it (and its schema) on first use."""
        mtopic = topics.mcap_topic(topic)
        cid = self._channels.get(mtopic)
        if cid is not None:
            return cid
        if mtopic.startswith(INVALID_PREFIX + "/"):
            cid = self._writer.register_channel(mtopic, RAW_ENCODING, 0)
        elif mtopic.startswith(REFUSED_PREFIX + "/"):
            cid = self._writer.register_channel(mtopic, "json", 0)
        else:
            try:
                cls = topics.type_of_topic(mtopic)
            except KeyError:
                cls = None
            if cls is None:
                cid = self._writer.register_channel(mtopic, "json", 0)
            else:
                sid = self._schemas.get(cls)
                if sid is None:
                    sid = self._writer.register_schema(codec.schema_name(cls), "jsonschema", codec.schema_bytes(cls))
                    self._schemas[cls] = sid
                cid = self._writer.register_channel(mtopic, "json", sid)
        self._channels[mtopic] = cid
        return cid

    # -- messages ----------------------------------------------------------------------------
    def write_foreign(self, topic: str, schema_name: str, schema_encoding: str, schema_data: bytes,
                      message_encoding: str, data: bytes, log_time_ns: int) -> None:
        """Record a message of a channel that is not in the ICD (e.g. a Foxglove well-known type in
        protobuf): the channel is registered with the given schema on first use."""
        if self.closed:
            raise ValueError(f"{self.path}: recorder is closed")
        cid = self._channels.get(topic)
        if cid is None:
            key = (schema_name, schema_encoding)
            sid = self._foreign_schemas.get(key)
            if sid is None:
                sid = self._foreign_schemas[key] = self._writer.register_schema(schema_name, schema_encoding, bytes(schema_data))
            cid = self._channels[topic] = self._writer.register_channel(topic, message_encoding, sid)
        self._writer.add_message(cid, log_time=int(log_time_ns), data=bytes(data), publish_time=int(log_time_ns), sequence=0)
        self.counts[topic] = self.counts.get(topic, 0) + 1
        self._dirty = True
        self.tick()

    def write(self, topic: str, payload: bytes, log_time_ns: int, publish_time_ns: int | None = None, sequence: int = 0) -> None:
        """Record an encoded payload (``publish_time_ns`` defaults to ``log_time_ns``)."""
        if self.closed:
            raise ValueError(f"{self.path}: recorder is closed")
        cid = self.channel_for(topic)
        self._writer.add_message(
            cid,
            log_time=int(log_time_ns),
            data=bytes(payload),
            publish_time=int(log_time_ns if publish_time_ns is None else publish_time_ns),
            sequence=sequence & 0xFFFFFFFF,
        )
        mtopic = topics.mcap_topic(topic)
        self.counts[mtopic] = self.counts.get(mtopic, 0) + 1
        self._dirty = True
        self.tick()

    def write_message(self, topic: str, message: Any, log_time_ns: int | None = None) -> None:
        """Encode and record an ICD message; ``publish_time`` from its ``timestamp``."""
        expected = topics.type_of_topic(topic)
        if not isinstance(message, expected):
            raise TypeError(f"{topic} carries {expected.__name__}, got {type(message).__name__}")
        self.write(topic, codec.to_json(message), time.time_ns() if log_time_ns is None else log_time_ns, publish_time_of(message))

    # -- run information ---------------------------------------------------------------------
    def add_metadata(self, name: str, data: dict[str, Any]) -> None:
        """A metadata record (values are stored as text; non-strings as JSON)."""
        self._writer.add_metadata(name, {str(k): v if isinstance(v, str) else json.dumps(v) for k, v in data.items()})
        self._dirty = True
        self.flush()

    def add_attachment(self, name: str, data: bytes, media_type: str = "application/octet-stream") -> None:
        """An attachment, e.g. the exact scenario YAML (``media_type='application/yaml'``)."""
        now = time.time_ns()
        self._writer.add_attachment(create_time=now, log_time=now, name=name, media_type=media_type, data=bytes(data))
        self._dirty = True
        self.flush()

    # -- durability --------------------------------------------------------------------------
    def tick(self) -> None:
        """Flush if the last flush is older than ``flush_interval_s`` (call it when idle too)."""
        if self._dirty and time.monotonic() - self._last_flush >= self.flush_interval_s:
            self.flush()

    def flush(self) -> None:
        """Close the open chunk and hand everything to the OS (survives a killed process)."""
        if self.closed:
            return
        self._writer.flush()
        self._file.flush()
        self._last_flush = time.monotonic()
        self._dirty = False

    def close(self) -> None:
        """Write the summary and footer and close the file (idempotent)."""
        if self.closed:
            return
        try:
            self._writer.finish()
            self._file.flush()
            os.fsync(self._file.fileno())
        finally:
            self._file.close()
            self.closed = True

    def __enter__(self) -> "McapRecorder":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

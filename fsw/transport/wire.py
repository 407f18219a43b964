"""How ICD messages look on a Zenoh sample: JSON with the schema name, a sequence attachment.

Every payload is the ICD's JSON; the Zenoh encoding is ``application/json;<schema name>`` (e.g.
``navbank.Measurement/v1``) so a receiver can refuse a payload of the wrong type before decoding
it. Publishers number their messages 0, 1, 2, ... and send the number as an 8-byte
little-endian attachment, so a subscriber can count the messages it never got (gaps): BLOCK
congestion control makes a live link lossless, but a link that was closed and re-opened loses
what was in flight without saying so.
"""

from __future__ import annotations

import struct
import time
from typing import Any

import zenoh

from fsw.interface import codec
from fsw.interface.messages import Stamp

_SEQ = struct.Struct("<Q")


def encoding(cls: type) -> zenoh.Encoding:
    """JSON tagged with the schema name of ICD type ``cls``."""
    return zenoh.Encoding.APPLICATION_JSON.with_schema(codec.schema_name(cls))


def schema_of(enc: Any) -> str:
    """The schema name carried by a sample's or query's encoding ('' if none)."""
    if enc is None:
        return ""
    text = str(enc)
    return text.split(";", 1)[1] if ";" in text else ""


def sequence_attachment(seq: int) -> bytes:
    """The attachment carrying publisher sequence number ``seq``."""
    return _SEQ.pack(seq)


def sequence_of(attachment: Any) -> int | None:
    """The publisher sequence number of a sample's attachment (None if it has none)."""
    if attachment is None:
        return None
    raw = attachment.to_bytes()
    return _SEQ.unpack(raw)[0] if len(raw) == _SEQ.size else None


def now_stamp() -> Stamp:
    return Stamp.from_unix(time.time())


def undeclare_quietly(entity: Any) -> None:
    """Undeclare a subscriber, queryable or publisher on a closing path: a link already gone
    (``zenoh.ZError``) must not keep the remaining entities from being undeclared."""
    try:
        entity.undeclare()
    except zenoh.ZError:
        pass

"""What a Zenoh sample of the ICD carries: the schema name in the encoding, the sequence attachment."""

from __future__ import annotations

import zenoh

from fsw.interface import codec, messages as m
from fsw.transport import wire


def test_encoding_names_the_schema_and_schema_of_reads_it_back():
    enc = wire.encoding(m.Measurement)
    assert wire.schema_of(enc) == codec.schema_name(m.Measurement)
    assert wire.schema_of(zenoh.Encoding.APPLICATION_JSON) == ""
    assert wire.schema_of(None) == ""


def test_sequence_attachment_round_trip_and_foreign_attachments():
    for seq in (0, 1, 2**32 + 5, 2**64 - 1):
        assert wire.sequence_of(zenoh.ZBytes(wire.sequence_attachment(seq))) == seq
    assert wire.sequence_attachment(1) == (1).to_bytes(8, "little")  # 8 bytes, little-endian, on every publisher
    assert wire.sequence_of(None) is None
    assert wire.sequence_of(zenoh.ZBytes(b"abc")) is None  # not ours: no sequence, not an error

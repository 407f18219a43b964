"""JSON encoding, strict decoding and JSON Schemas of the ICD messages.

The wire format is compact UTF-8 JSON of the message fields (no envelope); the message type and
schema version travel beside it (Zenoh encoding schema, MCAP schema name), as
``navbank.<Type>/v<version>``. Decoding is strict: a payload that is not valid JSON, has an
unknown or missing key, a wrong type or length, a non-finite number or an unknown enum value
raises :class:`ICDError` — never anything further down. Both directions run compiled
(:mod:`fsw.interface.compiled`, generated from the same declarations); what the compiled path
refuses goes through the reference implementation (:mod:`fsw.interface.typed`), which has the
last word on every refusal and its message.
"""

from __future__ import annotations

import json
import typing
from functools import lru_cache
from typing import Any, TypeVar

from fsw.interface import compiled, messages
from fsw.interface.typed import DecodeError, decode, encode, json_schema

T = TypeVar("T")

#: The largest payload any ICD message needs (an Estimate with a full 64 × 64 covariance is
#: ~100 kB); anything longer is refused unparsed, so no single payload can hold the decoder.
MAX_PAYLOAD_BYTES = 1 << 20


class ICDError(ValueError):
    """A payload does not conform to the ICD."""

    def __init__(self, type_name: str, path: str, expected: str, got: str):
        self.type_name = type_name
        self.path = path
        self.expected = expected
        self.got = got
        where = f"{type_name}.{path}" if path else type_name
        super().__init__(f"{where}: expected {expected}, got {got}")


def _reject_constant(token: str) -> Any:
    raise ValueError(f"non-finite number {token}")


def schema_name(cls: type) -> str:
    """``navbank.<Type>/v<version>``: the name under which a type's schema is published."""
    return f"navbank.{cls.__name__}/v{messages.SCHEMA_VERSION}"


def to_dict(msg: Any) -> dict:
    """JSON-compatible dict of a message."""
    return encode(msg)


def to_json(msg: Any) -> bytes:
    """Encode a message as compact JSON bytes (floats round-trip exactly)."""
    try:
        return compiled.encode(msg)
    except compiled.Refused:
        pass  # the reference encoder says why (or writes what msgspec would not)
    try:
        return json.dumps(encode(msg), separators=(",", ":"), allow_nan=False).encode()
    except ValueError as exc:  # a non-finite float slipped into a message built in code
        raise ICDError(type(msg).__name__, "", "finite numbers", str(exc)) from None


def from_dict(cls: type[T], data: Any) -> T:
    """Build and validate a message of type ``cls`` from already-parsed JSON data."""
    try:
        return decode(cls, data)
    except DecodeError as exc:
        raise ICDError(cls.__name__, exc.path, exc.expected, exc.got) from None
    except RecursionError:
        raise ICDError(cls.__name__, "", "a shallow JSON document", "excessive nesting") from None


def from_json(cls: type[T], payload: bytes | bytearray | memoryview | str) -> T:
    """Decode and validate a JSON payload as message type ``cls``.

    A payload longer than :data:`MAX_PAYLOAD_BYTES` is refused before it is parsed. The compiled
    decoder (:mod:`fsw.interface.compiled`) accepts what conforms; a payload it refuses goes
    through the reference decoder, whose error names the key path."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise ICDError(cls.__name__, "", f"a payload of at most {MAX_PAYLOAD_BYTES} bytes", f"{len(payload)} bytes")
    fast = compiled.decoder(typing.cast(type, cls))
    if fast is not None:
        try:
            return typing.cast(T, fast(payload))
        except compiled.Refused:
            pass
    try:
        if isinstance(payload, (bytes, bytearray, memoryview)):
            payload = bytes(payload).decode("utf-8")
        data = json.loads(payload, parse_constant=_reject_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise ICDError(cls.__name__, "", "UTF-8 JSON", f"unreadable payload ({exc.__class__.__name__}: {exc})"[:160]) from None
    return from_dict(cls, data)


@lru_cache(maxsize=None)
def _schema_text(cls: type) -> str:
    schema = json_schema(cls)
    schema["$id"] = schema_name(cls)
    return json.dumps(schema, indent=None, separators=(",", ":"))


def schema_of(cls: type) -> dict:
    """JSON Schema (draft 2020-12) of a message type, generated from its declaration."""
    return json.loads(_schema_text(cls))


def schema_bytes(cls: type) -> bytes:
    """The schema as bytes, ready for an MCAP ``jsonschema`` schema record."""
    return _schema_text(cls).encode()


def type_by_name(name: str) -> type:
    """ICD type from its class name or schema name (``navbank.Measurement/v1``)."""
    bare = name.removeprefix("navbank.").split("/")[0]
    try:
        return messages.MESSAGE_TYPES[bare]
    except KeyError:
        raise ICDError(bare, "", "a known ICD type (" + ", ".join(messages.MESSAGE_TYPES) + ")", repr(name)) from None

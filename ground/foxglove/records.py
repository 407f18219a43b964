"""One message of a Foxglove channel, ready for the MCAP writer or the live server."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any


#: MCAP topics of the channels the ground derives from the ICD ones: not part of the record that
#: replay re-sends or re-flies (a second logger derives them again).
DERIVED_PREFIXES = ("/foxglove/", "/plot/")


def is_derived(topic: str) -> bool:
    return ("/" + topic.strip("/") + "/").startswith(DERIVED_PREFIXES) or topic.startswith(DERIVED_PREFIXES)


@dataclass(frozen=True, slots=True)
class ChannelSchema:
    """A channel's schema as MCAP stores it: name, schema encoding, schema data, message encoding."""

    name: str
    encoding: str  # "protobuf" (well-known types) or "jsonschema"
    data: bytes
    message_encoding: str  # "protobuf" or "json"


@dataclass(frozen=True, slots=True)
class FoxgloveRecord:
    """An encoded message for ``topic`` (an MCAP topic), stamped with its mission ``log_time_ns``."""

    topic: str
    schema: ChannelSchema
    data: bytes
    log_time_ns: int


def well_known(cls: Any) -> ChannelSchema:
    """The schema of a ``foxglove.messages`` type, as the SDK defines it (protobuf)."""
    s = cls.get_schema()
    return ChannelSchema(s.name, s.encoding, bytes(s.data), "protobuf")


def json_schema(title: str, properties: dict[str, Any]) -> ChannelSchema:
    """A JSON Schema for a flat channel of numbers (the Plot panel's food)."""
    doc = {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": title, "type": "object",
           "properties": properties, "additionalProperties": {"type": "number"}}
    return ChannelSchema(title, "jsonschema", json.dumps(doc).encode(), "json")

"""What the ground logger hands every recorded message to: the Foxglove view's records go into
the same MCAP file and, with a live view, everything goes out over the WebSocket server too."""

from __future__ import annotations

from typing import Any

from fsw.interface import codec, topics
from ground.foxglove.live import LiveView
from ground.foxglove.records import ChannelSchema
from ground.foxglove.view import FoxgloveView, wanted
from ground.mcap_io.recorder import McapRecorder


class FoxgloveTap:
    """``tap(topic, cls, payload, message, log_ns)`` after each ICD message is recorded."""

    def __init__(self, rec: McapRecorder, view: FoxgloveView | None, live: LiveView | None):
        self.rec = rec
        self.view = view
        self.live = live
        self._icd_schemas: dict[type, ChannelSchema] = {}

    def __call__(self, topic: str, cls: type | None, payload: bytes, message: Any, log_ns: int) -> None:
        if self.live is not None and cls is not None:
            schema = self._icd_schemas.get(cls)
            if schema is None:
                schema = self._icd_schemas[cls] = ChannelSchema(codec.schema_name(cls), "jsonschema",
                                                                codec.schema_bytes(cls), "json")
            self.live.log(topics.mcap_topic(topic), schema, payload, log_ns)
        if self.view is None or cls is None or not wanted(topic):
            return
        for r in self.view.convert(topic, message if isinstance(message, dict) else payload, log_ns):
            s = r.schema
            self.rec.write_foreign(r.topic, s.name, s.encoding, s.data, s.message_encoding, r.data, r.log_time_ns)
            if self.live is not None:
                self.live.log(r.topic, s, r.data, r.log_time_ns)

    def close(self) -> None:
        if self.live is not None:
            self.live.close()

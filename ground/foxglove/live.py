"""The live view: the run's channels served over Foxglove's WebSocket protocol while it flies.

A ``foxglove-sdk`` WebSocket server (subprotocol ``foxglove.sdk.v1``) on its own context, bound to
127.0.0.1 unless told otherwise. The Foxglove view's own channels (scene, transforms, log) are
advertised as the server starts, so a client that connects before the run flies subscribes to
them before their first (static) scene message; the ICD channels are advertised as their first
message comes. The
server keeps a per-client backlog; the SDK's default (1024 messages) drops messages in the
bursts a run produces, hence the larger default here.
"""

from __future__ import annotations

import time
from typing import Any

from ground.foxglove.logs import LOG_SCHEMA, LOG_TOPIC
from ground.foxglove.records import ChannelSchema
from ground.foxglove.scene import SCENE_SCHEMA, SCENE_TOPIC, TRANSFORM_SCHEMA, TRANSFORM_TOPIC

DEFAULT_BACKLOG = 200_000
#: How long a closing server lets its clients take what is still queued for them (a run's last
#: messages are logged in a burst just before the logger closes).
CLOSE_LINGER_S = 1.0


class LiveView:
    """A running WebSocket server and its channels; :meth:`close` stops it."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, backlog: int = DEFAULT_BACKLOG):
        import foxglove

        self._foxglove = foxglove
        self._context = foxglove.Context()
        self._server = foxglove.start_server(name="navbank", host=host, port=port, context=self._context,
                                             message_backlog_size=backlog)
        self.host = host
        self._channels: dict[str, Any] = {}
        self.sent = 0
        for topic, schema in ((SCENE_TOPIC, SCENE_SCHEMA), (TRANSFORM_TOPIC, TRANSFORM_SCHEMA), (LOG_TOPIC, LOG_SCHEMA)):
            self.advertise(topic, schema)

    @property
    def port(self) -> int:
        return int(self._server.port)

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def advertise(self, topic: str, schema: ChannelSchema) -> Any:
        """The channel for ``topic``, created (and advertised to clients) if it is new."""
        ch = self._channels.get(topic)
        if ch is None:
            fg = self._foxglove
            ch = fg.Channel(topic, schema=fg.Schema(name=schema.name, encoding=schema.encoding, data=schema.data),
                            message_encoding=schema.message_encoding, context=self._context)
            self._channels[topic] = ch
        return ch

    def log(self, topic: str, schema: ChannelSchema, data: bytes, log_time_ns: int) -> None:
        self.advertise(topic, schema).log(bytes(data), log_time=int(log_time_ns))
        self.sent += 1

    def close(self) -> None:
        time.sleep(CLOSE_LINGER_S)
        self._server.stop()

"""MCAP recording of navbank runs: writer, crash-tolerant reader, recovery of footer-less files."""

from ground.mcap_io.reader import (
    LoggedMessage,
    McapReadError,
    StreamResult,
    is_complete,
    read_attachments,
    read_messages,
    read_metadata,
    recover,
    summary,
)
from ground.mcap_io.recorder import INVALID_PREFIX, McapRecorder

__all__ = [
    "INVALID_PREFIX",
    "LoggedMessage",
    "McapReadError",
    "McapRecorder",
    "is_complete",
    "read_messages",
    "read_attachments",
    "read_metadata",
    "StreamResult",
    "recover",
    "summary",
]

"""MCAP recording of navbank runs: writer, crash-tolerant reader, recovery of footer-less files."""

from ground.mcap_io.reader import LoggedMessage, McapReadError, is_complete, read_messages, read_metadata, recover, summary
from ground.mcap_io.recorder import INVALID_PREFIX, McapRecorder

__all__ = [
    "INVALID_PREFIX",
    "LoggedMessage",
    "McapReadError",
    "McapRecorder",
    "is_complete",
    "read_messages",
    "read_metadata",
    "recover",
    "summary",
]

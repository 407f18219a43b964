"""A recorded run as replay needs it: raw payload bytes in ``log_time`` order, run id, FSW config.

Republishing must send exactly the bytes the ground received, so messages are read as raw
records (not decoded), each with its MCAP topic, log/publish times, the publisher sequence
number the logger stored, and the channel's schema name. Complete files are read in
``log_time`` order through the seeking reader; files cut short (no footer) in file order, which
is the logger's receive order, up to the last complete chunk.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass


from ground.foxglove.records import is_derived
from ground.mcap_io.reader import is_complete, iter_channel_messages, read_attachments, read_metadata, summary
from ground.mcap_io.recorder import INVALID_PREFIX

#: Name of the attachment ``navbank run`` writes: the complete scenario YAML of the run.
CONFIG_ATTACHMENT = "config.yaml"


class RecordingError(ValueError):
    """The file lacks something replay needs (its run id, its configuration, any message)."""


@dataclass(frozen=True, slots=True)
class RawMessage:
    """One recorded message, undecoded."""

    topic: str  # MCAP topic, e.g. "/fsw/weights/chi2" or "/_invalid/sim/measurements"
    log_time_ns: int  # when the ground received it
    publish_time_ns: int  # the message's own timestamp
    sequence: int  # publisher sequence number (as stored by the logger, mod 2**32)
    data: bytes
    schema: str  # schema name, e.g. "navbank.Measurement/v1" ('' for schema-less channels)

    @property
    def zenoh_topic(self) -> str:
        """Topic to publish on: the key without run prefix; invalid payloads go back where they came from."""
        t = self.topic
        if t.startswith(INVALID_PREFIX + "/"):
            t = t[len(INVALID_PREFIX) :]
        return t.strip("/")


def iter_raw(path: str | os.PathLike, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
    """Every message of ``path`` (optionally only MCAP ``topics``) as :class:`RawMessage`; without
    ``topics``, the ICD record only (not the derived Foxglove channels)."""
    wanted = None if topics is None else {"/" + t.strip("/") for t in topics}
    for schema, channel, msg in iter_channel_messages(path, wanted, strict=False):
        if wanted is None and is_derived(channel.topic):
            continue  # the Foxglove view is made from the record, not part of it
        yield RawMessage(channel.topic, msg.log_time, msg.publish_time, msg.sequence, bytes(msg.data),
                         schema.name if schema is not None else "")


@dataclass(frozen=True)
class RunInfo:
    """What the file says about the run it holds."""

    path: str
    run_id: str  # '' if the file has no navbank.run metadata
    counts: dict[str, int]  # messages per MCAP topic
    complete: bool  # footer present
    config_text: str | None  # the attached scenario YAML, if any
    config_name: str  # its attachment name
    mission_time: bool = False  # log_time is each message's mission time (else the logger's receive time)
    wall_s: float | None = None  # how long the logger recorded, if it said


def run_info(path: str | os.PathLike) -> RunInfo:
    """Run id, per-topic counts and the attached configuration of a recorded run."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise RecordingError(f"{path}: no such file")
    complete = is_complete(path)  # also checks the magic (McapReadError, a ValueError)
    all_meta = read_metadata(path)
    meta = all_meta.get("navbank.run", {})
    attachments = read_attachments(path)
    name = CONFIG_ATTACHMENT if CONFIG_ATTACHMENT in attachments else next(
        (n for n, (media, _) in attachments.items() if media == "application/yaml"), "")
    text = None
    if name:
        try:
            text = attachments[name][1].decode("utf-8")
        except UnicodeDecodeError:
            raise RecordingError(f"{path}: attachment {name} is not UTF-8 text") from None
    try:
        wall_s: float | None = float(all_meta.get("navbank.logger", {})["elapsed_s"])
    except (KeyError, ValueError):
        wall_s = None
    counts = {t: n for t, n in summary(path).items() if not is_derived(t)}
    return RunInfo(path=path, run_id=meta.get("run_id", ""), counts=counts, complete=complete,
                   config_text=text, config_name=name, mission_time=meta.get("log_time") == "mission", wall_s=wall_s)

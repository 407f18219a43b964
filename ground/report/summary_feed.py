"""The run summary fed while the ground logger records, so that nothing has to read the recording
back once the run has ended.

Reading a 45-day run's recording back once its processes have stopped (~68,000 messages the
summary reads) costs 0.8 s on ``navbank run``'s wall time. The logger holds each
message as it writes it; a :class:`SummaryFeed` keeps, strictly decoded, the ones
:func:`~ground.report.run_summary.summarize` reads, in the order the read-back delivers them (by
log time; ties in recording order), so :meth:`SummaryFeed.summarize` is the summary of the
recording. A message that fails strict decoding spoils the feed (:attr:`SummaryFeed.spoiled`):
reading the recording back is then the only honest summary, and its error the one to show.
"""

from __future__ import annotations

from typing import Any

from fsw.interface import codec, topics
from ground.report.run_summary import reads_topic, summarize
from ground.report.summary_types import RunSummary


class SummaryFeed:
    """``feed(topic, cls, payload, message, log_ns)`` for every ICD message recorded, in recording order."""

    __slots__ = ("_kept", "_reads", "spoiled")

    def __init__(self) -> None:
        self._kept: list[tuple[int, str, Any]] = []
        # per topic: its MCAP topic if the summary reads it, else None (a run has a few dozen topics)
        self._reads: dict[str, str | None] = {}
        #: why the feed cannot stand for the recording (None: it can)
        self.spoiled: str | None = None

    def _channel(self, topic: str) -> str | None:
        try:
            return self._reads[topic]
        except KeyError:
            mtopic = topics.mcap_topic(topic)
            channel = self._reads[topic] = mtopic if reads_topic(mtopic) else None
            return channel

    def reads(self, topic: str) -> bool:
        """Whether the feed keeps the messages of ``topic`` (its ICD objects: a logger that decodes
        them strictly anyway hands them over decoded, and the feed decodes nothing again)."""
        return self._channel(topic) is not None

    def __call__(self, topic: str, cls: type, payload: bytes, message: Any, log_ns: int) -> None:
        channel = self._channel(topic)
        if channel is None or self.spoiled is not None:
            return
        if not isinstance(message, cls):  # the logger kept only the JSON value (it records without validating)
            try:
                message = codec.from_json(cls, payload)
            except codec.ICDError as exc:
                self.spoiled = f"{channel}: {exc}"
                self._kept.clear()
                return
        self._kept.append((log_ns, channel, message))

    def __len__(self) -> int:
        return len(self._kept)

    def messages(self) -> list[tuple[str, Any]]:
        """(MCAP topic, message) in log-time order, ties in recording order — the read-back's order
        (:func:`ground.mcap_io.reader.read_messages`)."""
        if self.spoiled is not None:
            raise ValueError(f"the recording holds a message that fails strict decoding ({self.spoiled})")
        return [(topic, msg) for _, topic, msg in sorted(self._kept, key=lambda k: k[0])]

    def summarize(self, *, scenario: str, seed: int, fault: str | None, t0: float,
                  wall_time_s: float | None = None) -> RunSummary:
        """:func:`~ground.report.run_summary.summarize` of what was fed."""
        return summarize(self.messages(), scenario=scenario, seed=seed, fault=fault, t0=t0, wall_time_s=wall_time_s)

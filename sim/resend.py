"""Measurements sent again to a restarted FSW, with their original sequence numbers.

A restarted FSW goes on from its last checkpoint and says so in its progress replies
(:class:`fsw.transport.ConsumerRestarted`, raised by the credit window or the end-of-stream
drain): everything after the checkpoint's last taken measurement must come again, numbered as it
was the first time, so the FSW takes the same stream and the logger drops what it already has.

What was sent is kept in order. The simulator generates its whole run before publishing, so
keeping references to its own measurements costs nothing beyond the list itself.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from fsw.interface.messages import Measurement
from fsw.transport import ConsumerRestarted, Publisher


#: Counters of the simulator's status that says it sent again: from which measurement, how many.
RESEND_FROM = "resend_from"
RESENT = "resent"


@dataclass(frozen=True)
class Rewind:
    """One restart as the simulator saw it."""

    resume_from: int  # first measurement sent again
    sent: int  # how many had been put when the restart was heard of (sent again: sent - resume_from)


@dataclass
class ResendingPublisher:
    """The measurement publisher, able to go back to where a restarted consumer stands."""

    pub: Publisher
    sent: list[Measurement] = field(default_factory=list)
    rewinds: list[Rewind] = field(default_factory=list)
    resent: int = 0  # measurements put more than once
    #: told of each restart before anything is sent again (the simulator says so on its status)
    on_rewind: Callable[[Rewind], None] | None = None
    _high: int = 0  # highest sequence number + 1 ever put

    def put(self, msg: Measurement) -> None:
        """Send ``msg`` (after whatever a restart asks to be sent again first)."""
        self.sent.append(msg)
        self._send_pending()

    def rewind(self, restart: ConsumerRestarted) -> None:
        """Go back to ``restart.resume_from`` and send everything from there again."""
        self._back_to(restart)
        self._send_pending()

    def _back_to(self, restart: ConsumerRestarted) -> None:
        k = max(0, min(restart.resume_from, len(self.sent)))
        rewind = Rewind(k, self._high)
        self.rewinds.append(rewind)
        self.pub.count = k
        if self.on_rewind is not None:
            self.on_rewind(rewind)

    def _send_pending(self) -> None:
        while self.pub.count < len(self.sent):
            seq = self.pub.count
            try:
                self.pub.put(self.sent[seq])  # the credit wait may hear of a restart first
            except ConsumerRestarted as restart:
                self._back_to(restart)
                continue
            if seq < self._high:
                self.resent += 1
            self._high = max(self._high, seq + 1)

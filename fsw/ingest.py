"""Measurement intake: sequence checking, bounded re-ordering, duplicate and gap accounting.

The simulator numbers its measurements 0, 1, 2, … in time order. A transport may still deliver
them late, twice, or not at all. ``SequenceGuard`` releases measurements strictly in sequence
order: an early arrival waits in a window of ``window`` sequence numbers for the missing ones;
when the window overflows (or at end of stream) the missing numbers are declared lost and
counted. A duplicate or a measurement older than what was already released is rejected and
counted — never processed twice, never allowed to move a filter backwards in time.
"""

from __future__ import annotations

import heapq
from collections import Counter
from dataclasses import dataclass, field
from typing import Iterator

from fsw.interface.messages import Measurement


@dataclass
class IntakeCounters:
    received: int = 0
    released: int = 0
    reordered: int = 0
    duplicates: int = 0
    late: int = 0
    lost: int = 0
    time_reversed: int = 0
    rejected: Counter = field(default_factory=Counter)

    def as_dict(self) -> dict[str, int]:
        out = {k: v for k, v in vars(self).items() if isinstance(v, int)}
        out["rejected"] = sum(self.rejected.values()) + self.duplicates + self.late + self.time_reversed
        for reason, n in sorted(self.rejected.items()):
            out[f"rejected_{reason}"] = n
        return out


class SequenceGuard:
    """Release measurements in sequence order (see the module docstring)."""

    def __init__(self, window: int = 32, first_seq: int = 0):
        self.window = int(window)
        self.next_seq = int(first_seq)
        self.counters = IntakeCounters()
        self._pending: list[tuple[int, Measurement]] = []
        self._pending_seqs: set[int] = set()
        self._last_t = float("-inf")
        self._lost: set[int] = set()

    @property
    def pending(self) -> int:
        return len(self._pending)

    def push(self, m: Measurement) -> Iterator[Measurement]:
        """Accept one measurement; yield those now releasable, in sequence order."""
        c = self.counters
        c.received += 1
        if m.seq < self.next_seq:
            if m.seq in self._lost:
                # it did arrive after all, too late to use: late, no longer lost
                self._lost.discard(m.seq)
                c.lost -= 1
                c.late += 1
            else:
                c.duplicates += 1
            return
        if m.seq in self._pending_seqs:
            c.duplicates += 1
            return
        if m.seq > self.next_seq:
            c.reordered += 1
        heapq.heappush(self._pending, (m.seq, m))
        self._pending_seqs.add(m.seq)
        yield from self._release(force=False)

    def flush(self) -> Iterator[Measurement]:
        """End of stream: release everything still waiting, counting the gaps as lost."""
        yield from self._release(force=True)

    def _release(self, force: bool) -> Iterator[Measurement]:
        c = self.counters
        while self._pending:
            seq, m = self._pending[0]
            if seq != self.next_seq:
                if not force and len(self._pending) <= self.window:
                    return
                c.lost += seq - self.next_seq
                self._lost.update(range(self.next_seq, seq))
                self.next_seq = seq
            heapq.heappop(self._pending)
            self._pending_seqs.discard(seq)
            self.next_seq = seq + 1
            if seq != m.seq:  # pragma: no cover - heap invariant
                raise AssertionError("sequence heap out of order")
            if m.t_s < self._last_t:
                # A measurement tagged earlier than one already processed would move the filters
                # backwards in time: reject it, whatever its sequence number says.
                c.time_reversed += 1
                continue
            self._last_t = m.t_s
            c.released += 1
            yield m

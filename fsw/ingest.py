"""Measurement intake: plausibility, sequence checking, bounded re-ordering, duplicate and gap accounting.

The simulator numbers its measurements 0, 1, 2, … in time order. A transport may still deliver
them late, twice, or not at all — and a hostile or broken sender may deliver anything the ICD
decodes. ``SequenceGuard`` therefore checks, before a measurement can change any state:

* **time tag plausibility** — a tag before the FSW's initial epoch (beyond the clock's phase
  error, ``START_TOLERANCE_S``), or more than
  ``max_ahead_s`` ahead of the FSW clock (the newest time tag released so far, the initial
  epoch before any), is rejected and counted (``rejected_before_start``, ``rejected_future``).
  It never advances the clock: one forged tag 60 days ahead would otherwise make every valid
  measurement after it look time-reversed, and a tag of 1e300 would make the executive run
  frames forever. Tracking gaps are days long (a weekly Doppler pass plan), so the horizon is
  configurable; its default, 10 days, is three times the longest gap of the built-in scenarios;
* **sequence plausibility** — a sequence number more than ``max_sequence_jump`` beyond the next
  expected one is rejected and counted (``rejected_sequence_jump``), not taken as a gap of
  2^62 lost measurements. A live sender is never that far ahead: the credit window keeps the
  simulator at most a few thousand measurements ahead of what the FSW has taken.

It then releases measurements strictly in sequence order: an early arrival waits in a window of
``window`` sequence numbers for the missing ones; when the window overflows (or at end of
stream) the missing numbers are declared lost and counted. A duplicate or a measurement older
than what was already released is rejected and counted — never processed twice, never allowed
to move a filter backwards in time. Memory stays bounded whatever arrives: at most ``window``
measurements wait, and lost sequence numbers are kept as at most ``MAX_LOST_RANGES`` ranges.
"""

from __future__ import annotations

import bisect
import heapq
import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Iterator

from fsw.interface.messages import Measurement

#: Onboard time tags carry the clock's phase error (microseconds), so a measurement made right at
#: the initial epoch may be tagged a little before it; only tags earlier than this are implausible.
START_TOLERANCE_S = 1.0

#: Lost sequence numbers are remembered (to tell a late arrival from a duplicate) as at most
#: this many ranges; the oldest are forgotten first (a measurement that late is a duplicate
#: for all purposes).
MAX_LOST_RANGES = 1024


@dataclass
class IntakeCounters:
    received: int = 0
    released: int = 0
    reordered: int = 0
    duplicates: int = 0
    late: int = 0
    lost: int = 0
    time_reversed: int = 0
    rejected: Counter[str] = field(default_factory=Counter)

    def as_dict(self) -> dict[str, int]:
        out = {k: v for k, v in vars(self).items() if isinstance(v, int)}
        out["rejected"] = sum(self.rejected.values()) + self.duplicates + self.late + self.time_reversed
        for reason, n in sorted(self.rejected.items()):
            out[f"rejected_{reason}"] = n
        return out


class LostRanges:
    """Sequence numbers declared lost, as sorted disjoint half-open ranges [start, end)."""

    def __init__(self, max_ranges: int = MAX_LOST_RANGES):
        self.max_ranges = max_ranges
        self._starts: list[int] = []
        self._ends: list[int] = []

    def add(self, start: int, end: int) -> None:
        """Declare [start, end) lost; ranges arrive in increasing order (sequence order)."""
        if end <= start:
            return
        if self._ends and self._ends[-1] == start:
            self._ends[-1] = end
        else:
            self._starts.append(start)
            self._ends.append(end)
        self._trim()

    def take(self, seq: int) -> bool:
        """Remove ``seq`` if it was lost (it arrived after all); whether it was."""
        i = bisect.bisect_right(self._starts, seq) - 1
        if i < 0 or seq >= self._ends[i]:
            return False
        start, end = self._starts[i], self._ends[i]
        pieces = [(a, b) for a, b in ((start, seq), (seq + 1, end)) if b > a]
        self._starts[i:i + 1] = [a for a, _ in pieces]
        self._ends[i:i + 1] = [b for _, b in pieces]
        self._trim()
        return True

    def _trim(self) -> None:
        while len(self._starts) > self.max_ranges:
            del self._starts[0], self._ends[0]

    def __len__(self) -> int:
        return len(self._starts)


class SequenceGuard:
    """Check and release measurements in sequence order (see the module docstring)."""

    # slotted: see fsw.executive.FrameExecutive
    __slots__ = ("window", "next_seq", "t_start", "max_ahead_s", "max_sequence_jump", "counters", "_pending",
                 "_pending_seqs", "_last_t", "_lost")

    def __init__(self, window: int = 32, first_seq: int = 0, *, t_start: float = -math.inf,
                 max_ahead_s: float = math.inf, max_sequence_jump: int | None = None):
        self.window = int(window)
        self.next_seq = int(first_seq)
        self.t_start = float(t_start)
        self.max_ahead_s = float(max_ahead_s)
        self.max_sequence_jump = max_sequence_jump
        self.counters = IntakeCounters()
        self._pending: list[tuple[int, Measurement]] = []
        self._pending_seqs: set[int] = set()
        self._last_t = -math.inf
        self._lost = LostRanges()

    @property
    def pending(self) -> int:
        return len(self._pending)

    @property
    def clock(self) -> float:
        """The FSW clock as the intake knows it: the newest time tag released (initial epoch before any)."""
        return max(self._last_t, self.t_start)

    def _implausible(self, m: Measurement) -> str | None:
        if m.t_s < self.t_start - START_TOLERANCE_S:
            return "before_start"
        if m.t_s - self.clock > self.max_ahead_s:
            return "future"
        if self.max_sequence_jump is not None and m.seq - self.next_seq > self.max_sequence_jump:
            return "sequence_jump"
        return None

    def push(self, m: Measurement) -> Iterator[Measurement]:
        """Accept one measurement; yield those now releasable, in sequence order."""
        c = self.counters
        c.received += 1
        reason = self._implausible(m)
        if reason is not None:
            c.rejected[reason] += 1
            return
        if m.seq < self.next_seq:
            if self._lost.take(m.seq):
                # it did arrive after all, too late to use: late, no longer lost
                c.lost -= 1
                c.late += 1
            else:
                c.duplicates += 1
            return
        if m.seq in self._pending_seqs:
            c.duplicates += 1
            return
        if m.seq == self.next_seq and not self._pending:
            # the usual case, the next measurement in order with nothing waiting: released at
            # once, as _release would release it, without going through the heap
            self.next_seq = m.seq + 1
            if m.t_s < self._last_t:
                c.time_reversed += 1
                return
            self._last_t = m.t_s
            c.released += 1
            yield m
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
                self._lost.add(self.next_seq, seq)
                self.next_seq = seq
            heapq.heappop(self._pending)
            self._pending_seqs.discard(seq)
            self.next_seq = seq + 1
            if m.t_s < self._last_t:
                # A measurement tagged earlier than one already processed would move the filters
                # backwards in time: reject it, whatever its sequence number says.
                c.time_reversed += 1
                continue
            self._last_t = m.t_s
            c.released += 1
            yield m

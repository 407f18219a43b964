"""Was the machine steady while ``navbank bench`` ran? The ``machine-steadiness`` row.

The rows whose goals are absolute figures (µs per measurement, seconds, runs per minute) are only
as good as the machine was steady while they were measured. On a shared virtual machine it may
not be: on one, a fixed pure-Python loop took 0.30-0.47 s of CPU in six runs one after the other
with nothing else running in the machine (other tenants of the host share its cores and caches),
and the FSW core's CPU per measurement scattered as much between runs. Rows that time ours and
their reference alternately (the FilterPy rows, a second worker's gain) are much less affected;
the absolute rows of such a run say little about a code change of a few per cent.

So the bench times one fixed workload (:func:`probe_s`: Python calls, small tuples and
dictionaries, and numpy calls on 3-vectors — the kind of work that sets the FSW core's pace, none
of navbank's code, so a change to navbank does not change it) at several points of the run:
before each group of rows and at the end. :class:`Steadiness` keeps those times and makes the
row: ours the slowest, the reference the fastest, the ratio slowest / fastest; the goal
``ratio <= 1.1`` is met by a run whose machine kept its speed within 10 %, and a run that misses
it should be repeated on a quieter machine before its absolute figures are believed. (The probe
sees the machine between the groups, not inside them: a slowdown that comes and goes within one
group's minute escapes it, so a met goal is necessary, not sufficient.)
"""

from __future__ import annotations

import math
import statistics
import time
from typing import Any

import numpy as np

from tools.bench.rows import Goal, make_row

#: slowest / fastest probe within 10 %: a steady machine
STEADINESS_GOAL = Goal("rate", "<=", 1.1)
#: probes per point; the point keeps the fastest (a single interruption is not a slower machine)
PROBES_PER_POINT = 3


def _workload(n: int = 20000) -> float:
    """A fixed mix of interpreter and small-array work (a few tens of ms of CPU)."""
    v = np.ones(3)
    table: dict[int, tuple[int, float]] = {}
    acc = 0.0
    for i in range(n):
        item = (i, float(i))
        table[i & 63] = item
        acc += math.sqrt(item[1]) + len(table)
        if i & 3 == 0:
            v = v * 0.5 + 1.0
            acc += float(v.sum())
    return acc


def probe_s() -> float:
    """Thread CPU seconds of the fixed workload, the fastest of :data:`PROBES_PER_POINT` runs."""
    best = math.inf
    for _ in range(PROBES_PER_POINT):
        t0 = time.thread_time()
        _workload()
        best = min(best, time.thread_time() - t0)
    return best


class Steadiness:
    """The probe's time at named points of a bench run."""

    def __init__(self) -> None:
        self.points: list[tuple[str, float]] = []

    def sample(self, label: str) -> float:
        """Time the probe now, before ``label`` (a group of rows, or ``end``); returns seconds."""
        seconds = probe_s()
        self.points.append((label, seconds))
        return seconds

    def row(self) -> dict[str, Any]:
        """The ``machine-steadiness`` row of the points sampled so far (at least one)."""
        if not self.points:
            raise ValueError("no probe has been timed")
        times = [s for _, s in self.points]
        slowest, fastest = max(times), min(times)
        return make_row("machine-steadiness", slowest * 1e3, fastest * 1e3, "ms CPU", STEADINESS_GOAL,
                        "slowest / fastest time of one fixed CPU workload at points through this run (<= 1.1: "
                        "the machine kept its speed; above, its absolute figures are uncertain by about "
                        "that factor: repeat on a quieter machine)",
                        probe_ms={label: round(s * 1e3, 3) for label, s in self.points},
                        median_ms=statistics.median(times) * 1e3, points=len(times))


__all__ = ["PROBES_PER_POINT", "STEADINESS_GOAL", "Steadiness", "probe_s"]

"""The measurement intake (fsw/ingest.py): plausibility before state, order, bounded memory.

The hostile cases are the ones measured against the FSW before the intake checked plausibility:
one measurement 60 days ahead blinded it for the rest of the run, a time tag of 1e300 hung it,
and a sequence number near 2^62 made it die of a MemoryError.
"""

from __future__ import annotations

import math
import tracemalloc

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw.ingest import MAX_LOST_RANGES, START_TOLERANCE_S, LostRanges, SequenceGuard
from fsw.interface import messages as m

T0 = 600_000_000.0
DAY = 86400.0


def meas(seq: int, t: float) -> m.Measurement:
    return m.Measurement(seq=seq, t_s=t, timestamp=m.Stamp(sec=0, nsec=0), kind="range", source="DSS-14",
                         value=(1.0e7,), sigma=(1e-3,))


def guard(**kw) -> SequenceGuard:
    kw = {"window": 8, "t_start": T0, "max_ahead_s": 10 * DAY, "max_sequence_jump": 100_000, **kw}
    return SequenceGuard(**kw)


def released(g: SequenceGuard, items) -> list[int]:
    out = []
    for x in items:
        out += [r.seq for r in g.push(x)]
    return out + [r.seq for r in g.flush()]


def stream(n: int, step: float = 60.0) -> list[m.Measurement]:
    return [meas(i, T0 + 10.0 + i * step) for i in range(n)]


def test_a_tag_far_ahead_is_rejected_and_never_moves_the_clock():
    good = stream(200)
    forged = meas(50, T0 + 60 * DAY)  # takes a valid sequence number before the real one arrives
    g = guard()
    out = released(g, [*good[:50], forged, *good[50:]])
    assert out == list(range(200))
    c = g.counters
    assert c.rejected["future"] == 1 and c.time_reversed == 0 and c.duplicates == 0 and c.lost == 0
    assert g.clock == good[-1].t_s


def test_an_absurd_tag_is_rejected_at_once():
    g = guard()
    assert list(g.push(meas(0, 1e300))) == []
    assert g.counters.rejected["future"] == 1 and g.clock == T0


def test_tags_before_the_initial_epoch_beyond_the_clock_phase_error_are_rejected():
    g = guard()
    assert [r.seq for r in g.push(meas(0, T0 - 0.5 * START_TOLERANCE_S))] == [0]  # clock phase error: fine
    assert list(g.push(meas(1, T0 - 2 * START_TOLERANCE_S))) == []
    assert g.counters.rejected["before_start"] == 1


def test_the_horizon_follows_the_clock_over_long_tracking_gaps():
    # a weekly pass plan: every step is 7 days, each within the 10-day horizon of the last tag
    g = guard()
    assert released(g, stream(5, step=7 * DAY)) == [0, 1, 2, 3, 4]
    assert not g.counters.rejected


def test_a_huge_sequence_jump_is_rejected_not_a_gap_of_2_62():
    good = stream(100)
    g = guard()
    tracemalloc.start()
    out = released(g, [*good[:40], meas(2**62, good[40].t_s), *good[40:]])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert out == list(range(100))
    assert g.counters.rejected["sequence_jump"] == 1 and g.counters.lost == 0
    assert peak < 5_000_000


def test_a_real_gap_is_counted_in_bounded_memory():
    # allowed jump (10^7 beyond): 10^7 lost sequence numbers kept as one range, not a set
    g = guard(max_sequence_jump=10**8)
    tracemalloc.start()
    out = released(g, [meas(0, T0 + 1), meas(10**7, T0 + 2), meas(10**7 + 1, T0 + 3)])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert out == [0, 10**7, 10**7 + 1]
    assert g.counters.lost == 10**7 - 1
    assert peak < 1_000_000


def test_a_late_arrival_leaves_the_lost_count_a_duplicate_does_not():
    g = guard(window=2)
    out = released(g, [meas(0, T0 + 1), meas(3, T0 + 4), meas(4, T0 + 5), meas(5, T0 + 6)])
    assert out == [0, 3, 4, 5] and g.counters.lost == 2
    assert list(g.push(meas(1, T0 + 2))) == []
    assert g.counters.lost == 1 and g.counters.late == 1
    assert list(g.push(meas(1, T0 + 2))) == []
    assert g.counters.duplicates == 1 and g.counters.late == 1


def test_lost_ranges_split_and_stay_bounded():
    lost = LostRanges(max_ranges=3)
    for a in (0, 10, 20, 30):
        lost.add(a, a + 5)
    assert len(lost) == 3 and not lost.take(2)  # the oldest range was forgotten
    assert lost.take(22) and not lost.take(22) and len(lost) == 3  # split in two, the oldest forgotten
    assert not lost.take(12) and lost.take(20) and lost.take(24) and not lost.take(25)
    assert MAX_LOST_RANGES >= 1000


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.integers(-5, 60), st.floats(-2 * DAY, 30 * DAY, allow_nan=False)), max_size=80),
       st.integers(0, 6))
def test_whatever_arrives_order_and_accounting_hold(items, window):
    """Any mix of sequence numbers and tags: releases are in strictly increasing sequence and
    non-decreasing time, within the horizon, and every measurement is accounted exactly once."""
    g = guard(window=window, max_ahead_s=5 * DAY, max_sequence_jump=20)
    pushed = [meas(s, T0 + t) for s, t in items if s >= 0]
    out: list[m.Measurement] = []
    for x in pushed:
        before = g.clock
        new = list(g.push(x))
        assert all(r.t_s - before <= 5 * DAY or r.t_s <= g.clock for r in new)
        out += new
    out += list(g.flush())
    seqs = [r.seq for r in out]
    assert seqs == sorted(set(seqs))
    assert all(a.t_s <= b.t_s for a, b in zip(out, out[1:]))
    assert all(r.t_s >= T0 - START_TOLERANCE_S for r in out)
    c = g.counters
    assert c.received == len(pushed)
    assert c.received == c.released + c.duplicates + c.late + c.time_reversed + sum(c.rejected.values())
    assert g.pending == 0 and c.lost >= 0 and not math.isnan(g.clock)

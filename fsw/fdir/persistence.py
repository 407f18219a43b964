"""k-of-n persistence: declare only when k of the last n batches exceed the threshold.

Hanlon & Maybeck 2000 §III notes that a single threshold crossing on noisy hypothesis statistics gives
momentary false declarations; requiring persistence trades a few batches of delay for a much
lower false-alarm rate. For calibration, a run's *critical value* is the largest threshold at
which the k-of-n rule would still declare on it: a window has at least k exceedances of h exactly
when its k-th largest value exceeds h, so the critical value is the maximum over windows of the
k-th largest D. A run declares at threshold h if and only if its critical value is > h, which turns
threshold selection into a quantile of per-run critical values.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view


class KOfN:
    """Sliding window of the last n exceedance flags."""

    def __init__(self, k: int, n: int):
        if not 1 <= k <= n:
            raise ValueError("persistence needs 1 <= k <= n")
        self.k = k
        self._flags: deque[bool] = deque(maxlen=n)
        self._count = 0

    def push(self, exceeded: bool) -> bool:
        """Add one batch; True when at least k of the last n batches exceeded."""
        if len(self._flags) == self._flags.maxlen and self._flags[0]:
            self._count -= 1
        self._flags.append(bool(exceeded))
        self._count += int(bool(exceeded))
        return self._count >= self.k

    def clear(self) -> None:
        self._flags.clear()
        self._count = 0


def critical_value(stat: np.ndarray, k: int, n: int) -> float:
    """Largest threshold at which the k-of-n rule declares on this sequence of D (−inf if the
    sequence has fewer than k batches, so it can never declare)."""
    d = np.asarray(stat, dtype=float)
    if d.size < k:
        return -np.inf
    width = min(n, d.size)
    windows = sliding_window_view(d, width)
    kth_largest = np.partition(windows, width - k, axis=1)[:, width - k]
    return float(kth_largest.max())

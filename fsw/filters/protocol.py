"""What the flight software asks of a filter bank, whichever filters it holds.

Both the EKF bank (:class:`fsw.filters.bank.FilterBank`) and the linear bank of Chaer et al.
1997's tracking example (:class:`fsw.filters.linear.LinearFilterBank`) satisfy :class:`Bank`:
they take ICD measurements, emit one :class:`~fsw.filters.record.BankRecord` per measurement for
the gating networks, obey filter enable/disable telecommands and give their estimates, with the
weighted-sum and best-filter ones of Chaer et al. 1997 eq. 3 when weights are given.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from fsw.filters.estimate import StateEstimate
from fsw.filters.record import BankRecord
from fsw.interface.messages import Measurement


@runtime_checkable
class Bank(Protocol):
    """A bank of filters advanced together over one measurement stream."""

    @property
    def names(self) -> tuple[str, ...]:
        """Filter names, bank order (the order of every per-filter array)."""
        ...

    @property
    def active(self) -> np.ndarray:
        """(N,) bool: False where a filter is disabled by telecommand."""
        ...

    @property
    def t(self) -> float:
        """Epoch of the bank's estimates."""
        ...

    @property
    def processed_count(self) -> int:
        """Measurements processed so far (rejected ones not counted)."""
        ...

    @property
    def rejected(self) -> Counter[str]:
        """Measurements refused, by reason (:data:`fsw.filters.errors.REJECT_REASONS`)."""
        ...

    def index(self, name: str) -> int:
        """Position of filter ``name`` in bank order (:class:`fsw.filters.errors.UnknownFilter`)."""
        ...

    def set_enabled(self, name: str, enabled: bool) -> None:
        """Enable or disable one filter."""
        ...

    def process(self, meas: Measurement) -> BankRecord:
        """Advance to the measurement, update the filters that process it, return its record;
        :class:`fsw.filters.errors.MeasurementRejected` (before any state changes) if unusable."""
        ...

    def propagate_to(self, t: float) -> None:
        """Advance every filter to epoch t without a measurement."""
        ...

    def estimates(self, weights: ArrayLike | None = None) -> Mapping[str, StateEstimate]:
        """Every filter's estimate; with gating weights also 'combined' and 'best'."""
        ...

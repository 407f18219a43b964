"""Typed errors of the anomaly detector.

Bad input to the detector is rejected before any state changes, so a caller that catches one of
these can keep feeding the same detector.
"""

from __future__ import annotations


class FdirInputError(ValueError):
    """A weight update the detector cannot use (NaN, wrong length, unknown filter, time reversal)."""

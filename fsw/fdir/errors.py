"""Typed errors of the anomaly detector and its calibration.

Bad input to the detector is rejected before any state changes, so a caller that catches one of
these can keep feeding the same detector.
"""

from __future__ import annotations


class FdirInputError(ValueError):
    """A weight update the detector cannot use (NaN, wrong length, unknown filter, time reversal)."""


class CalibrationError(ValueError):
    """Nominal histories that cannot produce a detector configuration (too few, inconsistent)."""

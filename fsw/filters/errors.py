"""Typed rejection of bad measurement input, raised before any filter state is touched."""

from __future__ import annotations

#: Every reason a bank may give for refusing a measurement (keys of ``bank.rejected``).
REJECT_REASONS: tuple[str, ...] = (
    "non_finite",  # NaN/inf in time tag, value, sigma or attitude
    "unknown_kind",  # a kind the bank has no model for
    "bad_dimension",  # value/sigma/attitude of the wrong length
    "bad_sigma",  # sigma <= 0
    "unknown_source",  # station or optical target the onboard models do not know
    "out_of_order",  # time tag earlier than the bank epoch
    "missing_field",  # e.g. an optical measurement without attitude_q
    "geometry",  # target behind the camera, zero-length line of sight
    "bad_count_time",  # Doppler count interval missing, non-finite or not positive
    "out_of_range",  # time tag outside the onboard ephemeris
)


class MeasurementRejected(ValueError):
    """A measurement the bank refuses to process; ``reason`` is one of :data:`REJECT_REASONS`."""

    def __init__(self, reason: str, detail: str):
        if reason not in REJECT_REASONS:
            raise ValueError(f"unknown rejection reason {reason!r}")
        self.reason = reason
        self.detail = detail
        super().__init__(f"measurement rejected ({reason}): {detail}")


class UnknownFilter(KeyError):
    """A filter name that is not in the bank (e.g. from a telecommand)."""

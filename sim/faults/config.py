"""Fault declarations: what goes wrong, by how much, from when to when.

A fault is a :class:`FaultConfig` (writable in YAML): its ``type``, ``onset_day`` and optional
``end_day`` (days since scenario start; no end = until the end of the run) and the magnitude
fields its type needs — exactly those, no others (a stray field is almost always a typo):

=====================  =====================================  ===========================
type                   magnitude fields                       anomaly class
=====================  =====================================  ===========================
``optical-bias``       ``sample_px``, ``line_px``             optical-measurement
``range-bias``         ``range_m``                            radiometric-measurement
``doppler-bias``       ``doppler_mhz``                        radiometric-measurement
``clock-bias``         ``phase_s`` and/or ``frequency``       radiometric-measurement
``thruster-mismodel``  ``bias_sigma_factor``,                 dynamics
                       ``daily_sigma_factor``
``thruster-scale``     ``scale``                              dynamics
``nga-level``          ``sigma_km_s2``                        dynamics
=====================  =====================================  ===========================

``nga-level`` changes the steady-state sigma of the truth's non-gravitational acceleration
(Chaer et al. 1998 §V: 0.7e-12 -> 7.0e-12 km/s^2 half-way through the cruise). The ECRV is not
restarted: from the first NGA batch edge at or after the onset it continues the same random
sequence by eq. 25 with q = sigma_new^2 (1 - exp(-2 dt/tau)) (eq. 26 with the new sigma), so
its variance relaxes from the old to the new steady state with time constant tau/2, as a
physical process whose driving noise changes would. It needs the NGA on
(``forces.nga_sigma_km_s2`` > 0) so there is a process to change.

Sign conventions. Biases are *added* to what the instrument reports: ``range_m`` to the range,
``sample_px``/``line_px`` to the centroid. A Doppler bias is a bias of the received frequency
shift; with navbank's one-way convention f_D = -(F/c) * range_rate (``fsw.astro.constants``),
``doppler_mhz`` > 0 *lowers* the reported range rate by ``doppler_mhz * MHZ_TO_KM_S`` km/s.
A clock bias is a step of the onboard clock itself (phase error ``phase_s`` [s] and fractional
frequency ``frequency`` [1]; see :mod:`sim.clock`), so range, Doppler and every time tag see it;
a Doppler count that straddles a phase step sees the whole step, c * phase_s / count time.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Literal

from fsw.interface.messages import AnomalyClass
from fsw.interface.typed import spec

FaultType = Literal[
    "optical-bias", "range-bias", "doppler-bias", "clock-bias", "thruster-mismodel", "thruster-scale", "nga-level"
]
FAULT_TYPES: tuple[str, ...] = (
    "optical-bias", "range-bias", "doppler-bias", "clock-bias", "thruster-mismodel", "thruster-scale", "nga-level"
)

#: The anomaly class a perfect diagnosis would give for each fault type (ICD ``AnomalyClass``).
FAULT_CLASS: dict[str, AnomalyClass] = {
    "optical-bias": "optical-measurement",
    "range-bias": "radiometric-measurement",
    "doppler-bias": "radiometric-measurement",
    "clock-bias": "radiometric-measurement",
    "thruster-mismodel": "dynamics",
    "thruster-scale": "dynamics",
    "nga-level": "dynamics",
}

#: Magnitude fields each type requires (clock-bias: at least one of the two).
REQUIRED: dict[str, tuple[str, ...]] = {
    "optical-bias": ("sample_px", "line_px"),
    "range-bias": ("range_m",),
    "doppler-bias": ("doppler_mhz",),
    "clock-bias": (),
    "thruster-mismodel": ("bias_sigma_factor", "daily_sigma_factor"),
    "thruster-scale": ("scale",),
    "nga-level": ("sigma_km_s2",),
}
ALLOWED: dict[str, tuple[str, ...]] = {**REQUIRED, "clock-bias": ("phase_s", "frequency")}
MAGNITUDE_FIELDS: tuple[str, ...] = (
    "sample_px", "line_px", "range_m", "doppler_mhz", "phase_s", "frequency",
    "bias_sigma_factor", "daily_sigma_factor", "scale", "sigma_km_s2",
)


@dataclass(frozen=True, slots=True)
class FaultConfig:
    """One injected fault: type, window (days since scenario start) and magnitude."""

    type: FaultType = spec(doc="fault type (docs/scenarios.md#faults: the fields each type takes)")
    onset_day: float = spec(doc="onset, days since scenario start", unit="day", ge=0.0)
    end_day: float | None = spec(None, doc="end, days since scenario start (none: until the end of the run)", unit="day")
    id: str = spec("", doc="identifier in truth/fault events (default: '<type>-<index>')")
    sample_px: float | None = spec(None, doc="optical-bias: sample bias", unit="px")
    line_px: float | None = spec(None, doc="optical-bias: line bias", unit="px")
    range_m: float | None = spec(None, doc="range-bias: bias added to the range", unit="m")
    doppler_mhz: float | None = spec(None, doc="doppler-bias: bias of the X-band Doppler shift", unit="mHz")
    phase_s: float | None = spec(None, doc="clock-bias: step of the onboard clock phase", unit="s")
    frequency: float | None = spec(None, doc="clock-bias: step of the onboard clock fractional frequency", unit="1")
    bias_sigma_factor: float | None = spec(
        None, doc="thruster-mismodel: per-thruster constant bias sigma, in units of the nominal ACS level", unit="1", ge=0.0
    )
    daily_sigma_factor: float | None = spec(
        None, doc="thruster-mismodel: daily magnitude variation sigma, in units of the nominal ACS level", unit="1", ge=0.0
    )
    scale: float | None = spec(None, doc="thruster-scale: factor on the ACS acceleration magnitude", unit="1", ge=0.0)
    sigma_km_s2: float | None = spec(
        None, doc="nga-level: new steady-state 1-sigma of the non-gravitational acceleration per axis",
        unit="km/s^2", ge=0.0,
    )

    def __post_init__(self) -> None:
        if self.type not in FAULT_TYPES:
            raise ValueError(f"unknown fault type {self.type!r}; known: {', '.join(FAULT_TYPES)}")
        for name in ("onset_day", "end_day", *MAGNITUDE_FIELDS):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, (int, float)) or value != value or abs(value) == float("inf")):
                raise ValueError(f"{self.type}: {name} must be a finite number, got {value!r}")
        if self.onset_day < 0.0:
            raise ValueError(f"{self.type}: onset_day must be >= 0, got {self.onset_day}")
        if self.end_day is not None and not self.end_day > self.onset_day:
            raise ValueError(f"{self.type}: end_day ({self.end_day}) must be after onset_day ({self.onset_day})")
        missing = [n for n in REQUIRED[self.type] if getattr(self, n) is None]
        if missing:
            raise ValueError(f"a {self.type} fault needs {', '.join(missing)}")
        if self.type == "clock-bias" and self.phase_s is None and self.frequency is None:
            raise ValueError("a clock-bias fault needs phase_s and/or frequency")
        stray = [n for n in MAGNITUDE_FIELDS if n not in ALLOWED[self.type] and getattr(self, n) is not None]
        if stray:
            raise ValueError(
                f"a {self.type} fault takes {', '.join(ALLOWED[self.type])}; it does not take {', '.join(stray)}"
            )
        for n in ("bias_sigma_factor", "daily_sigma_factor", "scale", "sigma_km_s2"):
            value = getattr(self, n)
            if value is not None and value < 0.0:
                raise ValueError(f"{self.type}: {n} must be >= 0, got {value}")

    @property
    def fault_class(self) -> AnomalyClass:
        """The ICD anomaly class of this fault."""
        return FAULT_CLASS[self.type]

    def magnitude(self) -> dict[str, float]:
        """The magnitude fields that are set, keyed with their units (for ``FaultEvent``)."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)
                if f.name in MAGNITUDE_FIELDS and getattr(self, f.name) is not None}


def fault_ids(faults: tuple[FaultConfig, ...]) -> tuple[str, ...]:
    """The identifier of each fault: its ``id`` or ``<type>-<index>``; duplicates are rejected."""
    ids = tuple(f.id or f"{f.type}-{i}" for i, f in enumerate(faults))
    if len(set(ids)) != len(ids):
        raise ValueError(f"fault identifiers must be unique, got {ids}")
    return ids

"""Named fault scenarios: Lubey & Ely 2022 Table 2 (measurement biases) and §4.4 (thruster mis-modelling).

Every preset starts at ``DEFAULT_ONSET_DAY`` (day 20 of the 45-day approach) unless the caller
gives another onset, and lasts to the end of the run.
"""

from __future__ import annotations

import dataclasses

from sim.faults.config import FaultConfig

DEFAULT_ONSET_DAY = 20.0
_ON = DEFAULT_ONSET_DAY


def _optical(s: float, l: float) -> tuple[FaultConfig, ...]:
    return (FaultConfig(type="optical-bias", onset_day=_ON, sample_px=s, line_px=l),)


def _radio(r_m: float, d_mhz: float) -> tuple[FaultConfig, ...]:
    return (
        FaultConfig(type="range-bias", onset_day=_ON, range_m=r_m),
        FaultConfig(type="doppler-bias", onset_day=_ON, doppler_mhz=d_mhz),
    )


#: name -> (one-line description, faults)
FAULT_PRESETS: dict[str, tuple[str, tuple[FaultConfig, ...]]] = {
    "none": ("no fault (nominal run)", ()),
    "optical-bias-small": ("optical centroid bias 0.2 px sample / 0.3 px line (Lubey & Ely 2022 Table 2, small)", _optical(0.2, 0.3)),
    "optical-bias-medium": ("optical centroid bias 2 px sample / 3 px line (Lubey & Ely 2022 Table 2, medium)", _optical(2.0, 3.0)),
    "optical-bias-large": ("optical centroid bias 20 px sample / 30 px line (Lubey & Ely 2022 Table 2, large)", _optical(20.0, 30.0)),
    "radio-bias-small": ("range bias 5 m with Doppler bias 0.03 mHz (Lubey & Ely 2022 Table 2, small)", _radio(5.0, 0.03)),
    "radio-bias-medium": ("range bias 50 m with Doppler bias 0.3 mHz (Lubey & Ely 2022 Table 2, medium)", _radio(50.0, 0.3)),
    "radio-bias-large": ("range bias 500 m with Doppler bias 3 mHz (Lubey & Ely 2022 Table 2, large)", _radio(500.0, 3.0)),
    "clock-bias": (
        "onboard clock steps by 1 us in phase (300 m of range) and 1e-13 in frequency (0.03 mm/s of range rate)",
        (FaultConfig(type="clock-bias", onset_day=_ON, phase_s=1.0e-6, frequency=1.0e-13),),
    ),
    "thruster-mismodel": (
        "attitude thrusters: per-thruster bias sigma 3x and daily variation sigma 10x the nominal level (Lubey & Ely 2022 §4.4)",
        (FaultConfig(type="thruster-mismodel", onset_day=_ON, bias_sigma_factor=3.0, daily_sigma_factor=10.0),),
    ),
    "thruster-scale": (
        "attitude-thruster acceleration 10x its nominal magnitude",
        (FaultConfig(type="thruster-scale", onset_day=_ON, scale=10.0),),
    ),
}


def preset(name: str, onset_day: float | None = None, end_day: float | None = None) -> tuple[FaultConfig, ...]:
    """The faults of preset ``name``, optionally with another onset (and an end)."""
    try:
        _, faults = FAULT_PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown fault preset {name!r}; known: {', '.join(FAULT_PRESETS)}") from None
    changes: dict = {}
    if onset_day is not None:
        changes["onset_day"] = float(onset_day)
    if end_day is not None:
        changes["end_day"] = float(end_day)
    return tuple(dataclasses.replace(f, **changes) for f in faults)

"""Configuration of the truth force model and of the InSight approach trajectory.

Spacecraft numbers (InSight in cruise configuration, public NASA/JPL facts):
* launch mass 694 kg (lander 358 kg, aeroshell, cruise stage); cruise propellant use neglected;
* SRP area 8.0 m^2: aeroshell of 2.64 m diameter (5.5 m^2 presented to the Sun) plus the two
  cruise-stage solar arrays (~2.5 m^2 together); Cr = 1.3 (cannonball, mostly absorbing/diffuse).
  This gives ~3.3e-11 km/s^2 of SRP near Mars (1.45 AU), ~7x the ACS level below.
Stochastic numbers: Lubey & Ely 2022 Table 1 (SRP scale factor 0.11 bias, 0.03 temporal, 1-day batches,
7-day correlation; ACS magnitude 3 % bias, 5 % daily, uncorrelated; 3 deg orientation bias)
and Lubey & Ely 2022 §4.4 (ACS nominal 5e-12 km/s^2; mis-modelled truth 3x bias, 10x daily; scale 10x).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

from fsw.interface.typed import spec


@dataclass(frozen=True, slots=True)
class ManeuverConfig:
    """An impulsive trajectory-correction maneuver (TCM)."""

    epoch_offset_days: float = spec(doc="epoch of the burn after the trajectory start", unit="day", ge=0.0)
    dv_km_s: tuple[float, ...] = spec(doc="velocity change, Mars-centred ICRF axes", unit="km/s", shape=(3,))
    dv_sigma_rel: float = spec(
        0.0, doc="1-sigma execution error per axis, as a fraction of |dv| (truth only)", unit="1", ge=0.0
    )

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in self.dv_km_s):
            raise ValueError("dv_km_s must be finite")


@dataclass(frozen=True, slots=True)
class ForceModelConfig:
    """Truth forces: Mars point mass, third bodies, cannonball SRP, ACS thrusting, TCMs."""

    include_sun: bool = spec(True, doc="Sun third-body gravity (with the indirect term)")
    include_earth: bool = spec(True, doc="Earth-Moon barycentre third-body gravity (with the indirect term)")
    include_jupiter: bool = spec(True, doc="Jupiter-system third-body gravity (with the indirect term)")

    srp_enabled: bool = spec(True, doc="cannonball solar radiation pressure")
    srp_area_m2: float = spec(8.0, doc="area presented to the Sun", unit="m^2", gt=0.0)
    srp_mass_kg: float = spec(694.0, doc="spacecraft mass", unit="kg", gt=0.0)
    srp_cr: float = spec(1.3, doc="reflectivity coefficient Cr", unit="1", ge=0.0, le=2.0)
    srp_bias_sigma: float = spec(0.11, doc="1-sigma constant bias of the SRP scale factor", unit="1", ge=0.0)
    srp_gm_sigma: float = spec(0.03, doc="steady-state 1-sigma of the Gauss-Markov part of the scale factor", unit="1", ge=0.0)
    srp_tau_days: float = spec(7.0, doc="correlation time of the Gauss-Markov part", unit="day", gt=0.0)
    srp_batch_days: float = spec(1.0, doc="the Gauss-Markov part is constant over batches of this length", unit="day", gt=0.0)

    acs_nominal_km_s2: float = spec(5e-12, doc="nominal attitude-thruster acceleration magnitude", unit="km/s^2", ge=0.0)
    acs_scale: float = spec(
        1.0, doc="multiplier on the true nominal magnitude (10 for the Lubey & Ely 2022 §4.4 process-noise case)", unit="1", ge=0.0
    )
    acs_bias_sigma_rel: float = spec(
        0.03, doc="1-sigma constant magnitude bias per thruster, fraction of nominal (3.0 in Lubey & Ely 2022 §4.4)", unit="1", ge=0.0
    )
    acs_daily_sigma_rel: float = spec(
        0.05, doc="1-sigma daily magnitude variation per thruster, fraction of nominal (10.0 in Lubey & Ely 2022 §4.4)",
        unit="1", ge=0.0,
    )
    acs_batch_days: float = spec(1.0, doc="the daily variation is constant over batches of this length", unit="day", gt=0.0)
    acs_direction_sigma_deg: float = spec(
        3.0, doc="1-sigma constant pointing error of each thruster, per transverse axis", unit="deg", ge=0.0
    )
    acs_directions_body: tuple[tuple[float, ...], ...] = spec(
        ((0.6, 0.0, 0.8),),
        doc="net thrust direction of each thruster group in the cruise body frame "
        "(z towards the Sun, x towards Earth across the Sun line); normalised on use",
        shape=(None, 3),
    )
    maneuvers: tuple[ManeuverConfig, ...] = spec((), doc="impulsive TCMs, in any order")
    nga_sigma_km_s2: float = spec(
        0.0, doc="steady-state 1-sigma of the non-gravitational acceleration ECRV per inertial axis "
        "(Chaer et al. 1998 eqs. 25-26); 0 switches it off", unit="km/s^2", ge=0.0,
    )
    nga_tau_days: float = spec(7.0, doc="correlation time of the non-gravitational acceleration", unit="day", gt=0.0)
    nga_batch_s: float = spec(
        3600.0, doc="the non-gravitational acceleration is constant over batches of this length", unit="s", gt=0.0
    )

    def __post_init__(self) -> None:
        if not self.acs_directions_body:
            raise ValueError("acs_directions_body needs at least one direction")
        for d in self.acs_directions_body:
            if len(d) != 3 or not all(math.isfinite(v) for v in d) or sum(v * v for v in d) == 0.0:
                raise ValueError(f"thruster direction {d!r} must be a finite non-zero 3-vector")

    def without_dispersions(self) -> "ForceModelConfig":
        """The same forces with every random part switched off (the design trajectory)."""
        return dataclasses.replace(
            self,
            srp_bias_sigma=0.0,
            srp_gm_sigma=0.0,
            acs_bias_sigma_rel=0.0,
            acs_daily_sigma_rel=0.0,
            acs_direction_sigma_deg=0.0,
            nga_sigma_km_s2=0.0,
            maneuvers=tuple(dataclasses.replace(m, dv_sigma_rel=0.0) for m in self.maneuvers),
        )


def thruster_mismodel_truth(forces: ForceModelConfig) -> ForceModelConfig:
    """Lubey & Ely 2022 §4.4 truth: per-thruster bias sigma 3x nominal, daily sigma 10x nominal."""
    return dataclasses.replace(forces, acs_bias_sigma_rel=3.0, acs_daily_sigma_rel=10.0)


def thruster_scale_truth(forces: ForceModelConfig) -> ForceModelConfig:
    """Lubey & Ely 2022 §4.4 process-noise case: the true nominal thrust is 10x what filters assume."""
    return dataclasses.replace(forces, acs_scale=10.0)


#: (launch, arrival) of each trajectory design's mission, ISO 8601 UTC (public NASA/JPL facts;
#: see :class:`TrajectoryConfig`).
MISSION_EPOCHS: dict[str, tuple[str, str]] = {
    "insight-approach": ("2018-05-05T11:05:00", "2018-11-26T19:52:59"),
    "pathfinder-cruise": ("1996-12-04T06:58:07", "1997-07-04T16:57:00"),
}


@dataclass(frozen=True, slots=True)
class TrajectoryConfig:
    """The trajectory: which built-in design (``kind``) and its defining numbers.

    ``insight-approach`` (the default) is the InSight-like approach; the entry-interface fields
    and ``span_days`` (the arc ending at entry) define it. ``pathfinder-cruise`` is the Mars
    Pathfinder-like Type-I cruise of :mod:`sim.trajectories.pathfinder`: the launch and arrival
    epochs define the Lambert transfer; the arc starts ``cruise_start_offset_days`` after
    launch and lasts ``span_days``.

    Public InSight EDL facts: entry 2018-11-26 ~19:47 UTC, entry-interface radius 3522.2 km
    (~128 km above the local surface at Elysium Planitia, 126 km above the equatorial radius),
    inertial flight-path angle -12.0 deg, ~5.5 km/s relative to the atmosphere. The inertial
    speed 5.75 km/s adds Mars' rotation for an eastward entry and gives v_inf ~ 2.95 km/s.
    Latitude, longitude and azimuth put the entry ~ 730 km up-range of the landing site
    (4.5 N, 135.6 E) and were chosen (a small search) so that the incoming asymptote is that of
    InSight's Type-I transfer: the heliocentric two-body orbit of the initial state passes
    within 0.002 AU of Earth at launch (2018-05-05 11:05 UTC) with v_inf 2.8 km/s (InSight's
    launch C3 of 8.2 km^2/s^2 is v_inf 2.86 km/s), perihelion 1.01 AU, 2.3 deg to the ecliptic.

    Launch and arrival epochs left null are the design's own mission's (:data:`MISSION_EPOCHS`):
    public NASA/JPL facts, InSight launched 2018-05-05 11:05 UTC from Vandenberg and landed
    2018-11-26 19:52:59 UTC (Earth-received time, as the entry epoch); Mars Pathfinder launched
    1996-12-04 06:58:07 UTC and landed 1997-07-04 16:57 UTC. Only pathfinder-cruise flies them
    (its Lambert transfer); the InSight approach is defined by its entry.
    """

    kind: Literal["insight-approach", "pathfinder-cruise"] = spec(
        "insight-approach", doc="built-in trajectory design: insight-approach or pathfinder-cruise"
    )
    entry_epoch_utc: str = spec("2018-11-26T19:47:00", doc="entry-interface epoch, ISO 8601 UTC")
    entry_radius_km: float = spec(3522.2, doc="entry-interface radius from Mars' centre", unit="km", gt=3396.19)
    entry_fpa_deg: float = spec(-12.0, doc="inertial flight-path angle at entry", unit="deg", gt=-90.0, lt=0.0)
    entry_speed_km_s: float = spec(5.75, doc="inertial speed at entry", unit="km/s", gt=0.0)
    entry_latitude_deg: float = spec(0.0, doc="planetocentric latitude of the entry point", unit="deg", ge=-90.0, le=90.0)
    entry_longitude_deg: float = spec(124.0, doc="east longitude of the entry point (IAU body-fixed)", unit="deg")
    entry_azimuth_deg: float = spec(77.0, doc="inertial heading at entry, clockwise from north", unit="deg")
    span_days: float = spec(
        45.0, doc="length of the arc (insight-approach: ending at entry; pathfinder-cruise: from its start)",
        unit="day", gt=0.0, le=400.0,
    )
    launch_epoch_utc: str | None = spec(
        None, doc="launch, ISO 8601 UTC; pathfinder-cruise: the Lambert departure from Earth; "
        "null: the design's mission (insight-approach: InSight 2018-05-05T11:05:00, pathfinder-cruise: "
        "Mars Pathfinder 1996-12-04T06:58:07)"
    )
    arrival_epoch_utc: str | None = spec(
        None, doc="Mars arrival, ISO 8601 UTC; pathfinder-cruise: the Lambert arrival at Mars' centre; "
        "null: the design's mission (insight-approach: InSight's landing 2018-11-26T19:52:59, "
        "pathfinder-cruise: Mars Pathfinder's 1997-07-04T16:57:00)"
    )
    cruise_start_offset_days: float = spec(
        1.0, doc="pathfinder-cruise: start of the simulated arc after launch", unit="day", gt=0.0
    )
    aim_days_before_arrival: float = spec(
        10.0, doc="pathfinder-cruise: the design trajectory is corrected to pass through the Lambert conic's "
        "position this long before arrival", unit="day", gt=0.0,
    )
    rtol: float = spec(1e-12, doc="integrator relative tolerance", unit="1", gt=0.0, lt=1e-3)
    atol_km: float = spec(1e-6, doc="integrator absolute tolerance on position", unit="km", gt=0.0)
    atol_km_s: float = spec(1e-12, doc="integrator absolute tolerance on velocity", unit="km/s", gt=0.0)
    ephemeris_step_s: float = spec(1800.0, doc="grid step of the interpolated ephemeris table", unit="s", gt=0.0)

    def launch_epoch(self) -> str:
        """The launch epoch, ISO 8601 UTC: the configured one, else the design's mission's."""
        return self.launch_epoch_utc or MISSION_EPOCHS[self.kind][0]

    def arrival_epoch(self) -> str:
        """The Mars arrival epoch, ISO 8601 UTC: the configured one, else the design's mission's."""
        return self.arrival_epoch_utc or MISSION_EPOCHS[self.kind][1]

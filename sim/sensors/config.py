"""Configuration of the simulated sensors: DSN one-way radiometrics and the optical camera.

Default noise levels and their sources:

* Range 1 m (1-sigma): DSN sequential/PN ranging at X-band, random error ~1 m or better at
  deep-space distances (DSN Telecommunications Link Design Handbook 810-005, modules 203/214).
* Doppler 0.1 mm/s (1-sigma) at a 60 s count: X-band Doppler noise of ~0.03–0.1 mm/s at 60 s
  (810-005 module 202); the conservative end is taken because one-way data also carry the
  onboard clock's short-term instability.
* Optical centroiding 0.25 px for the point-like moons, and max(0.25 px, 1e-3 x apparent
  diameter) for Mars, whose centre is found from a limb fit whose error grows with the disc.
  Lubey & Ely 2022 Table 2 calls its 0.2/0.3 px "small" bias "on the order of uncertainty in the
  measurements", which this matches.
* Attitude knowledge from the stars in each image (``attitude_from: stars``, see
  :mod:`sim.sensors.optical`): with stars to V = 10.5, ~27 in the 1.4 deg field on average (Liebe
  2002), 0.3 px centroids at the limit, the fit is ~1 urad cross-boresight (0.04 px) and ~0.1 mrad
  in roll. ``attitude_from: fixed`` keeps a constant 5 urad per axis (star-tracker class).
* Roll: sun-keeping (line axis away from the Sun) within a +-10 deg deadband.

Default schedule: three tracking passes a day, 3 h each, every 8 h from the scenario start,
each flown by the station (Goldstone, Canberra, Madrid) that sees the spacecraft highest over
the pass; range every 10 min and Doppler every 60 s while in a pass and above 10 deg; one
image every 30 min cycling Mars, Phobos, Deimos (the next visible target if the scheduled one
is not), and one of a visible asteroid beacon every 2 h. Over 45 days: ~24,000 Doppler, ~2,500
range and ~2,700 optical measurements (~2,160 of the Mars system, 540 of beacons).

Pass plan (``pass_plan``, replaces the daily schedule when given): each entry is one station
with its own periodic passes, e.g. Chaer et al.'s (1998) Mars Pathfinder cruise tracking, one 4-hour pass
a week per station, first passes on days 7 (DSS 15), 10 (DSS 45) and 12 (DSS 65). A pass on
day d is centred on the spacecraft's highest elevation at that station during
[start + d days, start + d + 1 days) (sampled every 10 min), so the station sees it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sim.truth.stations import station
from fsw.interface.typed import spec
from sim.sensors.asteroids import NAMES as ASTEROIDS


@dataclass(frozen=True, slots=True)
class PassPlan:
    """Periodic tracking passes of one station."""

    station: str = spec(doc="DSN station (sim.truth.stations name)")
    first_day: float = spec(doc="day of the first pass, days since scenario start", unit="day", ge=0.0)
    period_days: float = spec(7.0, doc="days between passes", unit="day", gt=0.0)
    duration_h: float = spec(4.0, doc="length of each pass", unit="h", gt=0.0, le=24.0)


@dataclass(frozen=True, slots=True)
class RadiometricConfig:
    """One-way uplink range and Doppler from the DSN, time-tagged by the onboard clock."""

    stations: tuple[str, ...] = spec(("DSS-14", "DSS-43", "DSS-63"), doc="candidate DSN stations (sim.truth.stations names)")
    passes_per_day: int = spec(3, doc="tracking passes per day, evenly spaced", ge=0, le=24)
    pass_duration_h: float = spec(3.0, doc="length of each tracking pass", unit="h", gt=0.0, le=24.0)
    first_pass_offset_h: float = spec(0.0, doc="start of the first pass after the scenario start", unit="h", ge=0.0)
    min_elevation_deg: float = spec(10.0, doc="minimum station elevation for a measurement", unit="deg", ge=-90.0, le=90.0)
    range_enabled: bool = spec(True, doc="generate range measurements")
    doppler_enabled: bool = spec(True, doc="generate Doppler measurements")
    range_interval_s: float = spec(600.0, doc="range cadence inside a pass", unit="s", gt=0.0)
    doppler_interval_s: float = spec(60.0, doc="Doppler cadence inside a pass", unit="s", gt=0.0)
    doppler_count_s: float = spec(60.0, doc="Doppler count interval ending at the time tag", unit="s", gt=0.0)
    range_sigma_m: float = spec(1.0, doc="range noise 1-sigma", unit="m", gt=0.0)
    doppler_sigma_mm_s: float = spec(0.1, doc="Doppler noise 1-sigma as range rate at the count interval", unit="mm/s", gt=0.0)
    range_bias_sigma_m: float = spec(
        2.0, doc="1-sigma of the constant range bias of a run (station delay calibration), drawn once per run",
        unit="m", ge=0.0)
    pass_plan: tuple[PassPlan, ...] = spec(
        (), doc="periodic passes per station; replaces the daily schedule (and the stations list) when given"
    )

    def __post_init__(self) -> None:
        if not self.stations:
            raise ValueError("at least one station is needed")
        for p in self.pass_plan:
            station(p.station)  # rejects unknown names here rather than mid-run
        if self.passes_per_day and self.pass_duration_h * self.passes_per_day > 24.0:
            raise ValueError("passes overlap: passes_per_day x pass_duration_h exceeds 24 h")


@dataclass(frozen=True, slots=True)
class OpticalConfig:
    """Narrow-angle camera imaging Mars, Phobos, Deimos and asteroid beacons against the stars."""

    enabled: bool = spec(True, doc="generate optical measurements")
    targets: tuple[str, ...] = spec(("mars", "phobos", "deimos"), doc="Mars-system targets, imaged in this cyclic order")
    image_interval_s: float = spec(1800.0, doc="image cadence", unit="s", gt=0.0)
    first_image_offset_s: float = spec(900.0, doc="first image after the scenario start", unit="s", ge=0.0)
    beacons: tuple[str, ...] = spec(ASTEROIDS, doc="asteroid beacons (sim.sensors.asteroids names); the visible ones are imaged in turn")
    beacon_interval_s: float = spec(7200.0, doc="cadence of the beacon images, between the Mars-system ones", unit="s", gt=0.0)
    first_beacon_offset_s: float = spec(1800.0, doc="first beacon image after the scenario start", unit="s", ge=0.0)
    pixels: int = spec(1024, doc="detector size (square)", unit="px", gt=0)
    pixel_pitch_um: float = spec(12.0, doc="pixel pitch", unit="um", gt=0.0)
    focal_length_mm: float = spec(500.0, doc="focal length", unit="mm", gt=0.0)
    principal_point_px: tuple[float, ...] = spec(
        (512.5, 512.5), doc="principal point [sample, line]; pixel k spans [k-0.5, k+0.5)", unit="px", shape=(2,)
    )
    roll: Literal["north", "sun", "random"] = spec(
        "sun", doc="roll about the boresight: line axis to ICRF north; sun-keeping (line axis away from the Sun, "
        "within the deadband); or uniformly random")
    roll_deadband_deg: float = spec(10.0, doc="sun-keeping roll: uniform roll error within +- this", unit="deg", ge=0.0, le=180.0)
    attitude_from: Literal["stars", "fixed"] = spec(
        "stars", doc="attitude knowledge from the stars in each image, or a fixed error of attitude_knowledge_urad")
    attitude_knowledge_urad: float = spec(5.0, doc="attitude_from fixed: knowledge error 1-sigma per camera axis", unit="urad", ge=0.0)
    limit_mag: float = spec(10.5, doc="faintest star or beacon (V magnitude) the navigation exposure detects", unit="mag")
    star_sigma_px: float = spec(0.3, doc="centroid noise 1-sigma of a star at the limiting magnitude", unit="px", gt=0.0)
    star_sigma_floor_px: float = spec(0.05, doc="centroid noise floor of bright stars", unit="px", gt=0.0)
    min_stars: int = spec(3, doc="fewest stars for an attitude fix; an image with fewer is not used", ge=2)
    pointing_control_mrad: float = spec(
        1.0, doc="pointing-control error 1-sigma per cross-boresight axis (target off-centre)", unit="mrad", ge=0.0
    )
    edge_margin_px: float = spec(10.0, doc="a target centre (or Mars' whole disc) must lie this far inside the image", unit="px", ge=0.0)
    sun_exclusion_deg: float = spec(30.0, doc="minimum angle between boresight and Sun", unit="deg", ge=0.0, le=180.0)
    glare_factor: float = spec(1.5, doc="a moon is lost in Mars' glare within this many Mars apparent radii", unit="1", ge=1.0)
    glare_margin_px: float = spec(5.0, doc="extra glare margin beyond glare_factor x Mars apparent radius", unit="px", ge=0.0)
    beacon_mars_keepout_deg: float = spec(2.0, doc="a beacon closer to Mars than this (or than the moons' glare limit, if larger) is lost in its stray light", unit="deg", ge=0.0)
    max_phase_deg: float = spec(120.0, doc="largest Sun-beacon-spacecraft phase angle imaged (H, G system's range)", unit="deg", gt=0.0, le=180.0)
    moon_sigma_px: float = spec(0.25, doc="centroid noise 1-sigma (sample and line) for Phobos, Deimos and beacons (floor)", unit="px", gt=0.0)
    mars_sigma_floor_px: float = spec(0.25, doc="Mars centre-finding noise floor", unit="px", gt=0.0)
    mars_sigma_fraction: float = spec(1e-3, doc="Mars centre-finding noise per pixel of apparent diameter", unit="1", ge=0.0)

    def __post_init__(self) -> None:
        known = {"mars", "phobos", "deimos"}
        if any(t not in known for t in self.targets) or len(set(self.targets)) != len(self.targets):
            raise ValueError(f"targets must be distinct names from {sorted(known)}, got {self.targets}")
        if any(b not in ASTEROIDS for b in self.beacons) or len(set(self.beacons)) != len(self.beacons):
            raise ValueError(f"beacons must be distinct names from {list(ASTEROIDS)}, got {self.beacons}")
        if not self.targets and not self.beacons:
            raise ValueError("at least one target or beacon is needed")

    @property
    def focal_px(self) -> float:
        """Focal length in pixels."""
        return self.focal_length_mm * 1e3 / self.pixel_pitch_um

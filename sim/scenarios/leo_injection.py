"""The launch-injection orbit-determination case of Garhwal, Halder & Sinha: ground-station
tracking of an Earth orbiter in its first minutes after injection.

The paper flies PSLV-C1 data (not public). navbank's stand-in is modelled on a public PSLV
sun-synchronous injection, PSLV-C40 (12 January 2018, Cartosat-2 series: liftoff 09:29 IST from
Sriharikota; ISRO's post-launch statement gives a flight of 16 min 37 s to a polar sun-synchronous
orbit of 503 km inclined at 97.55°, against the 505 km announced before launch). navbank flies a
505 km, i = 97.5° circular injection, within those figures' rounding; the injection is placed on a southbound (descending) pass at 15° S,
59° E, a few hundred kilometres north-east of ISTRAC's Mauritius station, which tracks it at
1 Hz in range, range rate, azimuth and elevation above a 5° mask. The paper states neither its
noise nor its dispersions; the figures below are navbank's own, stated here and in the
scenario's YAML: S-band tracking σ = 10 m, 5 cm/s, 0.02°, 0.02°; injection dispersion 2 km per
position axis and 5 m/s per velocity axis about the planned state; the a-priori handed to the
filters is the planned state (its σ, 10 km and 20 m/s per axis in the built-in scenario, is the
FSW's configuration: a poor a-priori, as in the paper).

Truth: :mod:`sim.dynamics.earth_orbit` (J2–J4, drag) with the truth Earth orientation and
stations (:mod:`sim.truth.tracking_stations`); the filters' own model is two-body + J2, no drag.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fsw.astro.constants import GM_EARTH, R_EARTH_EQ_KM
from fsw.interface import kinds
from fsw.interface.messages import Measurement, Stamp
from fsw.interface.typed import spec
from sim.dynamics.earth_orbit import EarthForceConfig, propagate
from sim.truth.earth import EarthOrientation
from sim.truth.timescales import tdb_to_unix, utc_iso_to_tdb
from sim.truth.tracking_stations import station_gcrs

KIND_ORDER: tuple[str, ...] = (kinds.STATION_RANGE.name, kinds.STATION_RANGE_RATE.name, kinds.AZIMUTH.name,
                               kinds.ELEVATION.name)


@dataclass(frozen=True, slots=True)
class LeoInjectionConfig:
    """Injection state, tracking, dispersions and a-priori of the leo-injection case."""

    epoch_utc: str = spec("2018-01-12T04:16:00", doc="injection epoch (UTC, ISO 8601)")
    altitude_km: float = spec(505.0, doc="planned perigee altitude of the (near-circular) injection orbit above the equatorial radius", unit="km", gt=100.0)
    eccentricity: float = spec(0.001, doc="planned eccentricity", unit="1", ge=0.0, lt=0.5)
    inclination_deg: float = spec(97.5, doc="planned inclination (sun-synchronous at ~505 km)", unit="deg", gt=0.0, lt=180.0)
    perigee_deg: float = spec(90.0, doc="planned argument of perigee", unit="deg")
    lat_deg: float = spec(-15.0, doc="latitude of the injection point (southbound pass)", unit="deg", ge=-80.0, le=80.0)
    lon_deg: float = spec(59.0, doc="longitude of the injection point", unit="deg")
    stations: tuple[str, ...] = spec(("mauritius",), doc="tracking stations (sim.truth.tracking_stations)", max_items=4)
    elevation_mask_deg: float = spec(5.0, doc="elevation mask of every station", unit="deg", ge=0.0, lt=90.0)
    arc_s: float = spec(400.0, doc="length of the tracking arc after injection", unit="s", gt=0.0, le=86400.0)
    rate_hz: float = spec(1.0, doc="measurement rate", unit="Hz", gt=0.0, le=10.0)
    sigma_range_km: float = spec(0.010, doc="range noise", unit="km", gt=0.0)
    sigma_range_rate_km_s: float = spec(5e-5, doc="range-rate noise", unit="km/s", gt=0.0)
    sigma_azimuth_deg: float = spec(0.02, doc="azimuth noise", unit="deg", gt=0.0)
    sigma_elevation_deg: float = spec(0.02, doc="elevation noise", unit="deg", gt=0.0)
    dispersion_pos_km: float = spec(2.0, doc="injection dispersion per position axis (1 sigma)", unit="km", ge=0.0)
    dispersion_vel_km_s: float = spec(0.005, doc="injection dispersion per velocity axis (1 sigma)", unit="km/s", ge=0.0)
    forces: EarthForceConfig = spec(EarthForceConfig(), doc="truth forces")

    @property
    def sigmas(self) -> tuple[float, float, float, float]:
        return (self.sigma_range_km, self.sigma_range_rate_km_s, math.radians(self.sigma_azimuth_deg),
                math.radians(self.sigma_elevation_deg))


def elements_to_state(a: float, e: float, i: float, raan: float, argp: float, nu: float) -> np.ndarray:
    """Classical elements (km, rad) -> GCRS [r, v] (km, km/s)."""
    p = a * (1 - e * e)
    r_pf = p / (1 + e * math.cos(nu)) * np.array([math.cos(nu), math.sin(nu), 0.0])
    v_pf = math.sqrt(GM_EARTH / p) * np.array([-math.sin(nu), e + math.cos(nu), 0.0])
    cO, sO, ci, si, cw, sw = math.cos(raan), math.sin(raan), math.cos(i), math.sin(i), math.cos(argp), math.sin(argp)
    R = np.array([[cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
                  [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
                  [sw * si, cw * si, ci]])
    return np.concatenate([R @ r_pf, R @ v_pf])


def planned_state(cfg: LeoInjectionConfig, t0: float, orientation: EarthOrientation) -> np.ndarray:
    """The planned injection state: the orbit of the configured elements passing southbound over
    the injection point at t0."""
    lat, lon = math.radians(cfg.lat_deg), math.radians(cfg.lon_deg)
    m, _ = orientation.matrices(np.array([t0]))
    p = m[0] @ np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    dec, ra = math.asin(p[2]), math.atan2(p[1], p[0])
    inc = math.radians(cfg.inclination_deg)
    s = math.sin(dec) / math.sin(inc)
    if abs(s) > 1.0:
        raise ValueError(f"an orbit of inclination {cfg.inclination_deg} deg never reaches latitude {cfg.lat_deg} deg")
    u = math.pi - math.asin(s)  # descending: argument of latitude in (90°, 270°)
    raan = ra - math.atan2(math.cos(inc) * math.sin(u), math.cos(u))
    argp = math.radians(cfg.perigee_deg)
    a = (R_EARTH_EQ_KM + cfg.altitude_km) / (1.0 - cfg.eccentricity)
    return elements_to_state(a, cfg.eccentricity, inc, raan, argp, u - argp)


@dataclass
class LeoRun:
    """One realisation: truth, measurements (ICD), the filters' a-priori."""

    t: np.ndarray  # (K,) TDB epochs of the arc
    truth: np.ndarray  # (K, 6) GCRS states
    measurements: list[Measurement]
    apriori: np.ndarray  # (6,) planned state handed to the filters (their sigmas are FSW configuration)
    visible: dict[str, np.ndarray] = field(default_factory=dict)  # station -> (K,) bool


def generate(cfg: LeoInjectionConfig, seed: int) -> LeoRun:
    """Truth arc and measurements of one seed (its own random stream)."""
    rng = np.random.default_rng(seed)
    t0 = utc_iso_to_tdb(cfg.epoch_utc)
    n = int(math.floor(cfg.arc_s * cfg.rate_hz + 1e-9)) + 1
    dt = np.arange(n) / cfg.rate_hz
    t = t0 + dt
    orientation = EarthOrientation(t0 - 600.0, t0 + cfg.arc_s + 600.0)
    planned = planned_state(cfg, t0, orientation)
    disp = np.concatenate([rng.normal(0.0, cfg.dispersion_pos_km, 3), rng.normal(0.0, cfg.dispersion_vel_km_s, 3)])
    truth = propagate(planned + disp, dt, cfg.forces)
    unix = tdb_to_unix(t)
    sig = cfg.sigmas
    rows: list[tuple[float, int, str, int, float]] = []  # (t, station index, station, component, value)
    visible: dict[str, np.ndarray] = {}
    for si, name in enumerate(cfg.stations):
        r_s, v_s, enu = station_gcrs(name, t, orientation)
        d = truth[:, 0:3] - r_s
        w = truth[:, 3:6] - v_s
        rho = np.linalg.norm(d, axis=1)
        el = np.arcsin(np.einsum("ij,ij->i", d, enu[:, 2]) / rho)
        az = np.mod(np.arctan2(np.einsum("ij,ij->i", d, enu[:, 0]), np.einsum("ij,ij->i", d, enu[:, 1])), 2 * math.pi)
        values = np.column_stack([rho, np.einsum("ij,ij->i", d, w) / rho, az, el])
        values = values + rng.normal(0.0, 1.0, values.shape) * np.asarray(sig)
        values[:, 2] = np.mod(values[:, 2], 2 * math.pi)
        vis = el > math.radians(cfg.elevation_mask_deg)
        visible[name] = vis
        for k in np.flatnonzero(vis):
            for c in range(4):
                rows.append((float(t[k]), si, name, c, float(values[k, c])))
    rows.sort(key=lambda r: (r[0], r[1], r[3]))
    k_of = {float(tk): k for k, tk in enumerate(t)}
    meas = [Measurement(seq=q, t_s=tk, timestamp=Stamp.from_unix(float(unix[k_of[tk]])), kind=KIND_ORDER[c],
                        source=name, value=(v,), sigma=(sig[c],))
            for q, (tk, _, name, c, v) in enumerate(rows)]
    return LeoRun(t=t, truth=truth, measurements=meas, apriori=planned, visible=visible)

"""Deep Space Network stations: positions, velocities and elevation angles.

ITRF coordinates of the 70 m antennas and of the 34 m high-efficiency antennas DSS 15, 45 and 65
(the stations of Chaer et al.'s (1998) Mars Pathfinder cruise) from the DSN Telecommunications Link Design
Handbook 810-005, module 301 (Rev. M, Table of station locations, ITRF93, epoch 2003.0; also in
NAIF's earth_topo_201023.tf). DSS 15 and DSS 45 are decommissioned; DSS 65 is at its post-2005
location, a few metres from where it tracked Pathfinder. The positions move with the handbook's
plate-motion velocity of each complex (2-5 cm/yr: 0.3-0.8 m between 2003.0 and 2018).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.earth import itrs_to_gcrs_matrix, itrs_to_gcrs_state, itrs_to_gcrs_state_and_pole, itrs_to_geodetic
from fsw.astro.ephemeris import EphemerisSource, default_ephemeris


_EPOCH_2003_S = 94651200.0  # 2003-01-01T00:00:00, seconds past J2000
_YEAR_S = 365.25 * 86400.0
# Plate motion per complex [km/yr] (810-005 module 301 Rev. M).
_PLATE_KM_YR = {
    "goldstone": (-0.0180e-3, 0.0065e-3, -0.0038e-3),
    "canberra": (-0.0335e-3, -0.0041e-3, 0.0392e-3),
    "madrid": (-0.0100e-3, 0.0242e-3, 0.0156e-3),
}


class StationError(ValueError):
    """Unknown station name or bad target vector."""


@dataclass(frozen=True)
class Station:
    """A ground station fixed in the ITRS."""

    name: str  # canonical, e.g. "DSS-14"
    complex: str  # "goldstone" | "canberra" | "madrid"
    itrs_km: tuple[float, float, float]  # at epoch 2003.0

    def itrs_at(self, t_tdb) -> np.ndarray:
        """ITRS position [km] at t_tdb: the 2003.0 position plus plate motion; (3,) or (N, 3)."""
        years = (np.asarray(t_tdb, dtype=float) - _EPOCH_2003_S) / _YEAR_S
        return np.asarray(self.itrs_km) + np.multiply.outer(years, np.asarray(_PLATE_KM_YR[self.complex]))

    @property
    def geodetic(self) -> tuple[float, float, float]:
        """(latitude deg, east longitude deg, height km) on WGS84."""
        lat, lon, h = itrs_to_geodetic(self.itrs_km)
        return math.degrees(lat), math.degrees(lon), h

    @property
    def up_itrs(self) -> np.ndarray:
        """Unit normal to the WGS84 ellipsoid at the station (local vertical)."""
        lat, lon, _ = itrs_to_geodetic(self.itrs_km)
        return np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])


STATIONS: dict[str, Station] = {
    "DSS-14": Station("DSS-14", "goldstone", (-2353.621420, -4641.341472, 3677.052318)),
    "DSS-43": Station("DSS-43", "canberra", (-4460.894917, 2682.361507, -3674.748152)),
    "DSS-63": Station("DSS-63", "madrid", (4849.092518, -360.180346, 4115.109251)),
    "DSS-15": Station("DSS-15", "goldstone", (-2353.538958, -4641.649429, 3676.669984)),
    "DSS-45": Station("DSS-45", "canberra", (-4460.935578, 2682.765661, -3674.380982)),
    "DSS-65": Station("DSS-65", "madrid", (4849.339634, -360.4276637, 4114.750733)),
}

_ALIASES = {
    "dss14": "DSS-14", "goldstone": "DSS-14", "gds": "DSS-14", "gdscc": "DSS-14",
    "dss43": "DSS-43", "canberra": "DSS-43", "cdscc": "DSS-43",
    "dss63": "DSS-63", "madrid": "DSS-63", "mdscc": "DSS-63",
    "dss15": "DSS-15", "dss45": "DSS-45", "dss65": "DSS-65",
}


def station(name: str) -> Station:
    """Look a station up by name or alias ("DSS-14", "dss14", "goldstone", ...)."""
    if not isinstance(name, str):
        raise StationError(f"station name must be a string, got {type(name).__name__}")
    key = name.strip().lower().replace("-", "").replace("_", "").replace(" ", "")
    try:
        return STATIONS[_ALIASES[key]]
    except KeyError:
        raise StationError(
            f"unknown station {name!r}; known: {', '.join(STATIONS)} (aliases: {', '.join(sorted(_ALIASES))})"
        ) from None


def station_state_icrf(name: str, t_tdb, dut1_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Geocentric ICRF (GCRS) position [km] and velocity [km/s]; scalar t -> (3,), (N,) -> (N, 3)."""
    st = station(name)
    # plate motion within one call's span (mm a month) is left out: the position at its first epoch
    return itrs_to_gcrs_state(st.itrs_at(float(np.min(t_tdb)) if np.size(t_tdb) else 0.0), t_tdb, dut1_s)


def station_states_and_pole_icrf(name: str, t_tdb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`station_states_icrf` and the celestial intermediate pole (N, 3) at the same epochs
    (the third column of :func:`fsw.astro.earth.itrs_to_gcrs_matrix`), sharing the rotation chain."""
    st = station(name)
    t = np.asarray(t_tdb, dtype=float)
    return itrs_to_gcrs_state_and_pole(st.itrs_at(t), t)


def station_states_icrf(name: str, t_tdb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Geocentric ICRF (GCRS) positions [km] and velocities [km/s] (N, 3) at the epochs t_tdb (N,),
    each with the plate motion of its own epoch (:func:`station_state_icrf` evaluated epoch by
    epoch, in one vectorised call)."""
    st = station(name)
    t = np.asarray(t_tdb, dtype=float)
    return itrs_to_gcrs_state(st.itrs_at(t), t)


def station_state_mars(
    name: str, t_tdb, ephemeris: EphemerisSource | None = None, dut1_s: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Mars-centred ICRF position [km] and velocity [km/s] of a station (adds Earth's state).

    ``ephemeris`` is anything with ``state(body, t, center)`` (an :class:`Ephemeris` or a
    Mars-centred :class:`EphemerisTable` containing ``earth``); default: DE421 directly.
    """
    eph = ephemeris if ephemeris is not None else default_ephemeris()
    pe, ve = eph.state("earth", t_tdb, "mars")
    ps, vs = station_state_icrf(name, t_tdb, dut1_s)
    return pe + ps, ve + vs


def elevation(name: str, t_tdb, target_pos_geocentric_km, dut1_s: float | None = None) -> np.ndarray | float:
    """Elevation [rad] of a target above a station's geodetic horizon.

    ``target_pos_geocentric_km``: geocentric ICRF target position(s), (3,) or (N, 3) matching t.
    Geometric direction: light time and aberration are the caller's choice of target position.
    """
    st = station(name)
    target = np.asarray(target_pos_geocentric_km, dtype=float)
    if target.shape[-1:] != (3,) or not np.all(np.isfinite(target)):
        raise StationError(f"target must be finite (..., 3) positions, got shape {target.shape}")
    M = itrs_to_gcrs_matrix(t_tdb, dut1_s)
    pos = M @ st.itrs_at(float(np.min(t_tdb)) if np.size(t_tdb) else 0.0)
    up = M @ st.up_itrs
    los = target - pos
    rng = np.linalg.norm(los, axis=-1)
    if np.any(rng == 0.0):
        raise StationError("target coincides with the station")
    sin_el = np.einsum("...i,...i->...", los, up) / rng
    el = np.arcsin(np.clip(sin_el, -1.0, 1.0))
    return float(el) if np.ndim(el) == 0 else el

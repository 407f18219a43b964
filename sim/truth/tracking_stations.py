"""Truth positions of the ground stations that track an Earth orbiter after injection.

The approximate locations of ISRO's telemetry, tracking and command station at Bigara,
Mauritius (in service since the 1986 India–Mauritius agreement) and of Sriharikota — town-level
positions to ~0.1°, not surveyed antenna coordinates, which is all a simulated station needs —,
WGS84 geodetic, turned into ITRS coordinates with ERFA's ``gd2gc``; the GCRS state and
the topocentric east/north/up axes come from the truth Earth orientation
(:class:`sim.truth.earth.EarthOrientation`: IAU 2006/2000A with the IERS C04 EOP).
"""

from __future__ import annotations

import math

import erfa
import numpy as np

from sim.truth.earth import EarthOrientation

#: name -> (geodetic latitude deg, longitude deg, height km)
GEODETIC: dict[str, tuple[float, float, float]] = {
    "mauritius": (-20.17, 57.50, 0.1),
    "sriharikota": (13.72, 80.23, 0.01),
}


class TruthTrackingStationError(ValueError):
    """Unknown tracking station."""


def _geodetic(name: str) -> tuple[float, float, float]:
    try:
        return GEODETIC[name]
    except KeyError:
        raise TruthTrackingStationError(f"unknown tracking station {name!r}; known: {', '.join(GEODETIC)}") from None


def itrs_km(name: str) -> np.ndarray:
    lat, lon, h = _geodetic(name)
    return np.asarray(erfa.gd2gc(1, math.radians(lon), math.radians(lat), h * 1e3)) / 1e3


def enu_itrs(name: str) -> np.ndarray:
    """Rows east, north, up (WGS84 normal) in the ITRS."""
    lat, lon, _ = (math.radians(v) for v in _geodetic(name))
    up = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    east = np.array([-math.sin(lon), math.cos(lon), 0.0])
    north = np.cross(up, east)
    return np.vstack([east, north, up])


def station_gcrs(name: str, t_tdb: np.ndarray, orientation: EarthOrientation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GCRS position (N, 3), velocity (N, 3) and east/north/up rows (N, 3, 3) at epochs t (N,)."""
    t = np.atleast_1d(np.asarray(t_tdb, dtype=float))
    m, dm = orientation.matrices(t)
    r0 = itrs_km(name)
    enu = enu_itrs(name) @ np.swapaxes(m, -1, -2)
    return m @ r0, dm @ r0, enu

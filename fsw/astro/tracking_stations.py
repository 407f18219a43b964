"""Ground stations that track an Earth orbiter just after injection (the leo-injection scenario).

Geodetic coordinates (WGS84) as uploaded to the onboard software. ISRO's telemetry, tracking and
command network (ISTRAC) tracks PSLV injections from, among others, its Mauritius station; the
coordinates below are an approximate (town-level, ~0.1°) location of that station at Bigara,
the height a nominal 0.1 km: not a surveyed antenna position, used the same way by the truth
(:mod:`sim.truth.tracking_stations`, written apart).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.earth import geodetic_to_itrs, itrs_to_gcrs_matrix, itrs_to_gcrs_state


class TrackingStationError(ValueError):
    """Unknown tracking station."""


@dataclass(frozen=True)
class TrackingStation:
    name: str
    lat_deg: float
    lon_deg: float
    h_km: float

    @property
    def itrs_km(self) -> np.ndarray:
        return geodetic_to_itrs(math.radians(self.lat_deg), math.radians(self.lon_deg), self.h_km)

    def enu_itrs(self) -> np.ndarray:
        """Rows east, north, up (the WGS84 normal) in the ITRS."""
        lat, lon = math.radians(self.lat_deg), math.radians(self.lon_deg)
        up = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
        east = np.array([-math.sin(lon), math.cos(lon), 0.0])
        return np.vstack([east, np.cross(up, east), up])


STATIONS: dict[str, TrackingStation] = {
    "mauritius": TrackingStation("mauritius", -20.17, 57.50, 0.1),
    "sriharikota": TrackingStation("sriharikota", 13.72, 80.23, 0.01),
}


def tracking_station(name: str) -> TrackingStation:
    try:
        return STATIONS[name]
    except KeyError:
        raise TrackingStationError(f"unknown tracking station {name!r}; known: {', '.join(STATIONS)}") from None


def station_frame_gcrs(name: str, t_tdb) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Station GCRS position (N, 3) [km], velocity (N, 3) [km/s] and its east/north/up rows
    (N, 3, 3) at epochs t (N,)."""
    st = tracking_station(name)
    t = np.atleast_1d(np.asarray(t_tdb, dtype=float))
    r, v = itrs_to_gcrs_state(st.itrs_km, t)
    m = itrs_to_gcrs_matrix(t)
    enu = st.enu_itrs() @ np.swapaxes(m, -1, -2)  # rows rotated: (M e)ᵀ = eᵀ Mᵀ
    return np.atleast_2d(r), np.atleast_2d(v), enu.reshape(t.size, 3, 3)

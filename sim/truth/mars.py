"""Truth Mars orientation: the IAU WGCCRE 2009 model with its secular pole drift.

Archinal et al. (2011): pole alpha0 = 317.68143 - 0.1061 T, delta0 = 52.88650 - 0.0609 T (deg,
T Julian centuries of TDB past J2000), prime meridian W = 176.630 + 350.89198226 d (d days of
TDB past J2000). The onboard model holds the pole at its J2000 value; the drift moves it by
0.02 deg by 2018 (~1 km at the Martian surface).
"""

from __future__ import annotations

import math

import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY

_CENTURY_S = 36525.0 * SECONDS_PER_DAY


def pole_radec_deg(t_tdb: float) -> tuple[float, float]:
    """Right ascension and declination [deg] of the Mars north pole at t_tdb."""
    T = float(t_tdb) / _CENTURY_S
    return 317.68143 - 0.1061 * T, 52.88650 - 0.0609 * T


def body_fixed_to_icrf_matrix(t_tdb: float) -> np.ndarray:
    """Rotation Mars body-fixed -> ICRF (v_icrf = M @ v_body_fixed): R3(-(90 + alpha0)) R1(-(90 - delta0)) R3(-W)."""
    ra, dec = (math.radians(v) for v in pole_radec_deg(t_tdb))
    w = math.radians((176.630 + 350.89198226 * float(t_tdb) / SECONDS_PER_DAY) % 360.0)
    z = np.array([math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)])
    x = np.array([-math.sin(ra), math.cos(ra), 0.0])  # ascending node of the Mars equator on the ICRF equator
    y = np.cross(z, x)
    node_frame = np.column_stack([x, y, z])
    c, s = math.cos(w), math.sin(w)
    return node_frame @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def areocentric_to_body_fixed(lat_rad: float, lon_east_rad: float, radius_km: float) -> np.ndarray:
    """Planetocentric latitude, east longitude and radius -> Mars body-fixed Cartesian [km]."""
    cl = math.cos(lat_rad)
    return radius_km * np.array([cl * math.cos(lon_east_rad), cl * math.sin(lon_east_rad), math.sin(lat_rad)])

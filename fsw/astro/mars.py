"""Mars orientation: equator frame and body-fixed (IAU 2009) frame relative to ICRF.

Frames
* Mars equator (of J2000): z = north pole (``MARS_POLE_RA_DEG``, ``MARS_POLE_DEC_DEG``),
  x = ascending node of the Mars equator on the ICRF equator.
* Mars body-fixed: the equator frame turned by the prime-meridian angle W(t) about z.
"""

from __future__ import annotations

import math

import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY
from fsw.astro.frames import pole_frame

# IAU WGCCRE 2009 Mars rotation model (Archinal et al. 2011): north pole at J2000 (the secular
# drift, -0.1061 and -0.0609 deg/century, is below 0.02 deg over 2018 and is neglected) and
# prime meridian W = W0 + rate * d, d in days of TDB past J2000.
MARS_POLE_RA_DEG: float = 317.68143
MARS_POLE_DEC_DEG: float = 52.88650
MARS_W0_DEG: float = 176.630
MARS_W_RATE_DEG_PER_DAY: float = 350.89198226

# Columns: Mars-equator frame axes expressed in ICRF (v_icrf = M @ v_equator).
MARS_EQUATOR_TO_ICRF: np.ndarray = pole_frame(math.radians(MARS_POLE_RA_DEG), math.radians(MARS_POLE_DEC_DEG))
MARS_ROTATION_RATE_RAD_S: float = math.radians(MARS_W_RATE_DEG_PER_DAY) / SECONDS_PER_DAY


def prime_meridian_angle(t_tdb):
    """W [rad, 0..2pi) of the Mars prime meridian from the equator-frame x axis."""
    d = np.asarray(t_tdb, dtype=float) / SECONDS_PER_DAY
    w = np.radians(np.mod(MARS_W0_DEG + MARS_W_RATE_DEG_PER_DAY * d, 360.0))
    return float(w) if w.ndim == 0 else w


def body_fixed_to_icrf_matrix(t_tdb: float) -> np.ndarray:
    """Rotation Mars body-fixed -> ICRF at one epoch (v_icrf = M @ v_body_fixed)."""
    w = prime_meridian_angle(float(t_tdb))
    c, s = math.cos(w), math.sin(w)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return MARS_EQUATOR_TO_ICRF @ turn


def areocentric_to_body_fixed(lat_rad: float, lon_east_rad: float, radius_km: float) -> np.ndarray:
    """Planetocentric latitude / east longitude / radius -> body-fixed Cartesian [km]."""
    cl = math.cos(lat_rad)
    return radius_km * np.array([cl * math.cos(lon_east_rad), cl * math.sin(lon_east_rad), math.sin(lat_rad)])

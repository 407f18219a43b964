"""Earth orientation: ITRS (Earth-fixed) <-> GCRS (ICRF axes, geocentric).

IERS Conventions 2010 CIO-based transformation, ``r_GCRS = Q(t) R(t) W(t) r_ITRS``:

* R(t) = R3(-ERA), Earth Rotation Angle (IAU 2000 B1.8, eq. 5.15) from UT1, with UT1 = UTC +
  ``dut1_s`` (default 0; |UT1-UTC| < 0.9 s, i.e. up to ~0.4 km at the equator if left at 0;
  in late 2018 it was below 0.1 s, ~40 m).
* Q(t) from the CIP coordinates X, Y (eq. 5.10 closed form) with the polynomial
  precession part and the largest nutation terms (Tables 5.2a/b: 18.6 yr, semi-annual,
  fortnightly, 9.3 yr, annual); s = -XY/2. Omitted terms are < 0.1 arcsec (~3 m at the surface).
  Ignoring Q entirely would cost ~400 arcsec in 2018 (~12 km), which is why it is kept.
* W(t) (polar motion, ~0.3 arcsec ~ 10 m) is the identity.

The velocity includes Earth rotation and the (small) rate of Q, so it is the time derivative of
the position function to < 1e-12 km/s.
"""

from __future__ import annotations

import math

import numpy as np

from fsw.astro.constants import ERA_RATE_CYCLES_PER_UT1_DAY, F_EARTH, R_EARTH_EQ_KM, SECONDS_PER_DAY
from fsw.astro.time import tdb_to_naive_utc, tdb_to_tt_centuries

_UAS = math.pi / (180.0 * 3600.0 * 1e6)  # microarcsecond in rad
_AS = math.pi / (180.0 * 3600.0)


def era_from_ut1_days(du) -> np.ndarray | float:
    """Earth Rotation Angle [rad, 0..2pi) for UT1 days past JD 2451545.0 (IAU 2000 B1.8)."""
    du = np.asarray(du, dtype=float)
    # frac(du) keeps precision: 1.00273781191135448*du = du + 0.00273781191135448*du.
    frac = np.mod(du, 1.0)
    era = 2.0 * np.pi * np.mod(0.7790572732640 + frac + (ERA_RATE_CYCLES_PER_UT1_DAY - 1.0) * du, 1.0)
    return float(era) if era.ndim == 0 else era


def earth_rotation_angle(t_tdb, dut1_s: float = 0.0):
    """ERA [rad] at t_tdb with UT1 = UTC + dut1_s."""
    return era_from_ut1_days((tdb_to_naive_utc(t_tdb) + dut1_s) / SECONDS_PER_DAY)


def cip_xy(t_tdb) -> tuple[np.ndarray, np.ndarray]:
    """CIP coordinates X, Y [rad] in the GCRS (IERS 2010 Tables 5.2a/b, truncated)."""
    T = np.asarray(tdb_to_tt_centuries(t_tdb), dtype=float)
    # Delaunay arguments (IERS 2010 eq. 5.43), arcsec -> rad.
    lp = (1287104.79305 + 129596181.0481 * T) * _AS
    F = (335779.526232 + 1739527262.8478 * T) * _AS
    D = (1072260.70369 + 1602961601.2090 * T) * _AS
    Om = (450160.398036 - 6962890.5431 * T) * _AS
    a1 = 2 * F - 2 * D + 2 * Om
    a2 = 2 * F + 2 * Om
    X = (-16617.0 + 2004191898.0 * T - 429782.9 * T**2 - 198618.34 * T**3 + 7.578 * T**4 + 5.9285 * T**5
         - 6844318.44 * np.sin(Om) - 523908.04 * np.sin(a1) - 90552.22 * np.sin(a2)
         + 82168.76 * np.sin(2 * Om) + 58707.02 * np.sin(lp))
    Y = (-6951.0 - 25896.0 * T - 22407274.7 * T**2 + 1900.59 * T**3 + 1112.526 * T**4 + 0.1358 * T**5
         + 9205236.26 * np.cos(Om) + 573033.42 * np.cos(a1) + 97846.69 * np.cos(a2)
         - 89618.24 * np.cos(2 * Om))
    return X * _UAS, Y * _UAS


def cirs_to_gcrs_matrix(t_tdb) -> np.ndarray:
    """Q(t) (IERS 2010 eq. 5.10): CIRS -> GCRS; (3, 3) or (N, 3, 3)."""
    X, Y = cip_xy(t_tdb)
    a = 1.0 / (1.0 + np.sqrt(1.0 - X * X - Y * Y))
    m = np.empty(np.shape(X) + (3, 3))
    m[..., 0, 0] = 1 - a * X * X
    m[..., 0, 1] = -a * X * Y
    m[..., 0, 2] = X
    m[..., 1, 0] = -a * X * Y
    m[..., 1, 1] = 1 - a * Y * Y
    m[..., 1, 2] = Y
    m[..., 2, 0] = -X
    m[..., 2, 1] = -Y
    m[..., 2, 2] = 1 - a * (X * X + Y * Y)
    s = -X * Y / 2.0
    cs, ss = np.cos(s), np.sin(s)
    r3s = np.zeros(np.shape(X) + (3, 3))
    r3s[..., 0, 0] = cs
    r3s[..., 0, 1] = ss
    r3s[..., 1, 0] = -ss
    r3s[..., 1, 1] = cs
    r3s[..., 2, 2] = 1.0
    return m @ r3s


def _r3_neg(theta):
    c, s = np.cos(theta), np.sin(theta)
    m = np.zeros(np.shape(theta) + (3, 3))
    m[..., 0, 0] = c
    m[..., 0, 1] = -s
    m[..., 1, 0] = s
    m[..., 1, 1] = c
    m[..., 2, 2] = 1.0
    return m


def itrs_to_gcrs_matrix(t_tdb, dut1_s: float = 0.0) -> np.ndarray:
    """Rotation ITRS -> GCRS at t_tdb; (3, 3) or (N, 3, 3)."""
    return cirs_to_gcrs_matrix(t_tdb) @ _r3_neg(earth_rotation_angle(t_tdb, dut1_s))


def itrs_to_gcrs_state(r_itrs_km, t_tdb, dut1_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """GCRS position [km] and velocity [km/s] of a point fixed in the ITRS.

    ``r_itrs_km`` is (3,); t scalar -> (3,) outputs, t (N,) -> (N, 3).
    """
    r = np.asarray(r_itrs_km, dtype=float)
    t = np.asarray(t_tdb, dtype=float)
    theta = earth_rotation_angle(t, dut1_s)
    R = _r3_neg(theta)
    c, s = np.cos(theta), np.sin(theta)
    dR = np.zeros(np.shape(theta) + (3, 3))
    dR[..., 0, 0] = -s
    dR[..., 0, 1] = -c
    dR[..., 1, 0] = c
    dR[..., 1, 1] = -s
    omega = 2.0 * np.pi * ERA_RATE_CYCLES_PER_UT1_DAY / SECONDS_PER_DAY
    dR *= omega
    h = 3600.0  # Q varies over >= 5.5 days; a central difference over +-1 h is exact enough
    Q = cirs_to_gcrs_matrix(t)
    dQ = (cirs_to_gcrs_matrix(t + h) - cirs_to_gcrs_matrix(t - h)) / (2 * h)
    pos = (Q @ R) @ r
    vel = (Q @ dR + dQ @ R) @ r
    return pos, vel


def geodetic_to_itrs(lat_rad: float, lon_rad: float, h_km: float) -> np.ndarray:
    """WGS84 geodetic latitude/longitude/height -> ITRS Cartesian [km]."""
    e2 = F_EARTH * (2 - F_EARTH)
    n = R_EARTH_EQ_KM / math.sqrt(1 - e2 * math.sin(lat_rad) ** 2)
    return np.array([
        (n + h_km) * math.cos(lat_rad) * math.cos(lon_rad),
        (n + h_km) * math.cos(lat_rad) * math.sin(lon_rad),
        (n * (1 - e2) + h_km) * math.sin(lat_rad),
    ])


def itrs_to_geodetic(r_km) -> tuple[float, float, float]:
    """ITRS Cartesian [km] -> WGS84 (geodetic latitude rad, longitude rad, height km)."""
    x, y, z = (float(v) for v in np.asarray(r_km, dtype=float))
    e2 = F_EARTH * (2 - F_EARTH)
    p = math.hypot(x, y)
    lon = math.atan2(y, x)
    lat = math.atan2(z, p * (1 - e2))
    for _ in range(10):
        n = R_EARTH_EQ_KM / math.sqrt(1 - e2 * math.sin(lat) ** 2)
        h = p / math.cos(lat) - n
        lat_new = math.atan2(z, p * (1 - e2 * n / (n + h)))
        if abs(lat_new - lat) < 1e-15:
            lat = lat_new
            break
        lat = lat_new
    n = R_EARTH_EQ_KM / math.sqrt(1 - e2 * math.sin(lat) ** 2)
    return lat, lon, p / math.cos(lat) - n

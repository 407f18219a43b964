"""Earth orientation onboard: ITRS (Earth-fixed) <-> GCRS (ICRF axes, geocentric).

IERS Conventions 2010 CIO-based transformation, ``r_GCRS = Q(t) R(t) W(t) r_ITRS``:

* Q(t) from the CIP coordinates X, Y and the CIO locator s of the IAU 2000B model (ERFA
  ``xys00b``: the 77 largest luni-solar nutation terms and fixed planetary offsets), ~1 mas from
  IAU 2006/2000A, i.e. ~1-2 cm at the surface. Ignoring Q entirely would cost ~400 arcsec in
  2018 (~12 km), a truncation to the five largest terms ~0.1 arcsec (~3 m).
* R(t) = R3(-ERA), Earth Rotation Angle (IAU 2000 B1.8, eq. 5.15) from UT1.
* W(t) = polar motion from the pole coordinates x, y (s' is left out: < 0.1 mas).

UT1-UTC and the pole coordinates are the Earth orientation uplinked with the daily tracking
products (``data/eop_uploaded.csv``: the IERS C04 values at 0h UTC of each day), interpolated
linearly, UT1-UTC through UT1-TAI so that a leap second does not smear; the velocity uses the
interpolant's UT1 rate. A weekly upload instead was measured to leave 0.33 m and 0.024 mm/s at
the stations, which biased the fused filter (NEES ~3x its dimension); daily leaves 2 cm and
0.001 mm/s. Outside the uploaded spans UT1 = UTC and the pole is at the origin, which errs up to
|UT1-UTC| x 465 m/s (< 0.9 s, i.e. < 0.4 km) and ~0.3 arcsec (~10 m). An explicit ``dut1_s``
replaces the table's UT1-UTC (and the pole) where given.

The velocity includes Earth rotation and the (small) rate of Q, so it is the time derivative of
the position function to < 1e-12 km/s.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import erfa
import numpy as np

from fsw.astro.constants import ERA_RATE_CYCLES_PER_UT1_DAY, F_EARTH, R_EARTH_EQ_KM, SECONDS_PER_DAY
from fsw.astro.time import naive_utc_to_tai, tdb_to_naive_utc, tdb_to_tt_centuries

_EOP_FILE = Path(__file__).with_name("data") / "eop_uploaded.csv"


@lru_cache(maxsize=1)
def _uploaded_eop() -> tuple[np.ndarray, np.ndarray, list[tuple[float, float]]]:
    """(naive UTC s of each sample, columns [UT1-UTC, x rad, y rad], spans of consecutive weeks)."""
    data = np.loadtxt(_EOP_FILE, delimiter=",", comments="#", skiprows=3)
    u = (data[:, 0] - 51544.5) * SECONDS_PER_DAY  # 0h UTC as naive UTC seconds past J2000 noon
    cols = np.column_stack([data[:, 3], np.radians(data[:, 1] / 3600.0), np.radians(data[:, 2] / 3600.0)])
    breaks = np.flatnonzero(np.diff(data[:, 0]) != 1.0) + 1
    spans = [(float(a[0]), float(a[-1])) for a in np.split(u, breaks)]
    return u, cols, spans


@lru_cache(maxsize=1)
def _eop_spans() -> tuple[tuple[float, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray], ...]:
    """Per uploaded span: (first, last, sample epochs, UT1-TAI, x, y) — what every lookup
    interpolates in, taken out of the table once rather than at each lookup."""
    u, cols, spans = _uploaded_eop()
    tai_rows = np.asarray(naive_utc_to_tai(u), dtype=float) - u  # TAI-UTC of each sample
    out = []
    for lo, hi in spans:
        sel = (u >= lo) & (u <= hi)
        out.append((lo, hi, u[sel], cols[sel, 0] - tai_rows[sel], cols[sel, 1], cols[sel, 2]))
    return tuple(out)


def _eop_and_ut1_tai(t_tdb) -> tuple[np.ndarray, np.ndarray]:
    """([UT1-UTC, x, y] (N, 3), UT1-TAI (N,)) at t_tdb; UT1-TAI is NaN outside the uploaded spans."""
    u_q = np.atleast_1d(np.asarray(tdb_to_naive_utc(t_tdb), dtype=float))
    dat_q = np.asarray(naive_utc_to_tai(u_q), dtype=float) - u_q
    out = np.zeros((u_q.size, 3))
    ut1_tai = np.full(u_q.size, np.nan)
    for lo, hi, u, ut1_tai_rows, x_rows, y_rows in _eop_spans():
        inside = (u_q >= lo) & (u_q <= hi)
        if inside.any():
            ut1_tai[inside] = np.interp(u_q[inside], u, ut1_tai_rows)
            out[inside, 0] = ut1_tai[inside] + dat_q[inside]
            out[inside, 1] = np.interp(u_q[inside], u, x_rows)
            out[inside, 2] = np.interp(u_q[inside], u, y_rows)
    return out, ut1_tai


def uploaded_eop(t_tdb) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """UT1-UTC [s], pole x and y [rad] at t_tdb from the uploaded table; zeros outside it.

    UT1-UTC is interpolated as UT1-TAI so that a leap second between samples does not smear.
    """
    out, _ = _eop_and_ut1_tai(t_tdb)
    return out[:, 0], out[:, 1], out[:, 2]


def ut1_rate(t_tdb) -> np.ndarray:
    """d(UT1-TAI)/dt [s/s] of the uploaded table (0 outside it): the slope, not smeared by a leap second."""
    t = np.asarray(t_tdb, dtype=float)
    return _ut1_rate_from(_eop_and_ut1_tai(np.concatenate(_rate_epochs(t)))[1], t)


#: Half-width of the central difference :func:`ut1_rate` takes [s].
_UT1_RATE_DH = 60.0


def _rate_epochs(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The epochs t + dh and t − dh :func:`ut1_rate` differences, flattened."""
    flat = t.reshape(-1)
    return flat + _UT1_RATE_DH, flat - _UT1_RATE_DH


def _ut1_rate_from(ut1_tai: np.ndarray, t: np.ndarray) -> np.ndarray:
    """:func:`ut1_rate` at t from UT1-TAI at the epochs of :func:`_rate_epochs` (in that order)."""
    n = ut1_tai.size // 2
    rate = (ut1_tai[:n] - ut1_tai[n:]) / (2 * _UT1_RATE_DH)
    return np.where(np.isfinite(rate), rate, 0.0).reshape(np.shape(t))


_UAS = math.pi / (180.0 * 3600.0 * 1e6)  # microarcsecond in rad
_AS = math.pi / (180.0 * 3600.0)


def era_from_ut1_days(du) -> np.ndarray | float:
    """Earth Rotation Angle [rad, 0..2pi) for UT1 days past JD 2451545.0 (IAU 2000 B1.8)."""
    du = np.asarray(du, dtype=float)
    # frac(du) keeps precision: 1.00273781191135448*du = du + 0.00273781191135448*du.
    frac = np.mod(du, 1.0)
    era = 2.0 * np.pi * np.mod(0.7790572732640 + frac + (ERA_RATE_CYCLES_PER_UT1_DAY - 1.0) * du, 1.0)
    return float(era) if era.ndim == 0 else era


def earth_rotation_angle(t_tdb, dut1_s: float | None = None):
    """ERA [rad] at t_tdb with UT1 = UTC + dut1_s (default: the uploaded UT1-UTC)."""
    return _era(t_tdb, dut1_s, None)


def _era(t_tdb, dut1_s: float | None, eop: np.ndarray | None):
    """:func:`earth_rotation_angle`, reading UT1-UTC from ``eop`` (the uploaded EOP at t_tdb,
    :func:`_eop_and_ut1_tai`) when given."""
    if dut1_s is None:
        dut1 = (eop if eop is not None else _eop_and_ut1_tai(t_tdb)[0])[:, 0]
        dut1_arr: np.ndarray | float = dut1 if np.ndim(t_tdb) else float(dut1[0])
    else:
        dut1_arr = dut1_s
    return era_from_ut1_days((tdb_to_naive_utc(t_tdb) + dut1_arr) / SECONDS_PER_DAY)


def polar_motion_matrix(t_tdb, dut1_s: float | None = None) -> np.ndarray:
    """W (ITRS -> TIRS) from the uploaded pole; identity where ``dut1_s`` is given explicitly."""
    return _polar_motion(t_tdb, dut1_s, None)


def _polar_motion(t_tdb, dut1_s: float | None, eop: np.ndarray | None) -> np.ndarray:
    """:func:`polar_motion_matrix`, reading the pole from ``eop`` (as :func:`_era`) when given."""
    n = np.shape(t_tdb)
    if dut1_s is not None:
        return np.broadcast_to(np.eye(3), n + (3, 3)).copy()
    e = eop if eop is not None else _eop_and_ut1_tai(t_tdb)[0]
    w = np.swapaxes(erfa.pom00(e[:, 1], e[:, 2], 0.0), -1, -2)
    return w.reshape(n + (3, 3))


def cip_xys(t_tdb) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CIP coordinates X, Y and CIO locator s [rad] in the GCRS (IAU 2000B, ERFA ``xys00b``)."""
    T = np.asarray(tdb_to_tt_centuries(t_tdb), dtype=float)
    return erfa.xys00b(2451545.0, T * 36525.0)


def cip_xy(t_tdb) -> tuple[np.ndarray, np.ndarray]:
    """CIP coordinates X, Y [rad] in the GCRS (IAU 2000B)."""
    X, Y, _ = cip_xys(t_tdb)
    return X, Y


def cirs_to_gcrs_matrix(t_tdb) -> np.ndarray:
    """Q(t) (IERS 2010 eq. 5.10): CIRS -> GCRS; (3, 3) or (N, 3, 3)."""
    X, Y, s = cip_xys(t_tdb)
    return np.swapaxes(erfa.c2ixys(X, Y, s), -1, -2)


def _r3_neg(theta):
    c, s = np.cos(theta), np.sin(theta)
    m = np.zeros(np.shape(theta) + (3, 3))
    m[..., 0, 0] = c
    m[..., 0, 1] = -s
    m[..., 1, 0] = s
    m[..., 1, 1] = c
    m[..., 2, 2] = 1.0
    return m


def itrs_to_gcrs_matrix(t_tdb, dut1_s: float | None = None) -> np.ndarray:
    """Rotation ITRS -> GCRS at t_tdb; (3, 3) or (N, 3, 3)."""
    return cirs_to_gcrs_matrix(t_tdb) @ _r3_neg(earth_rotation_angle(t_tdb, dut1_s)) @ polar_motion_matrix(t_tdb, dut1_s)


def itrs_to_gcrs_state(r_itrs_km, t_tdb, dut1_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """GCRS position [km] and velocity [km/s] of a point fixed in the ITRS.

    ``r_itrs_km`` is (3,) or, with t (N,), one point per epoch (N, 3); t scalar -> (3,)
    outputs, t (N,) -> (N, 3).
    """
    pos, vel, _ = _itrs_to_gcrs(r_itrs_km, t_tdb, dut1_s, False)
    return pos, vel


def itrs_to_gcrs_state_and_pole(r_itrs_km, t_tdb) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`itrs_to_gcrs_state` (uploaded EOP) and the celestial intermediate pole, the third
    column of :func:`itrs_to_gcrs_matrix`, from one evaluation of the rotation chain."""
    pos, vel, k = _itrs_to_gcrs(r_itrs_km, t_tdb, None, True)
    assert k is not None
    return pos, vel, k


def _itrs_to_gcrs(r_itrs_km, t_tdb, dut1_s: float | None,
                  pole: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    t = np.asarray(t_tdb, dtype=float)
    flat = t.reshape(-1)
    n = flat.size
    eop: np.ndarray | None = None
    rate = np.zeros(t.shape)
    if dut1_s is None:
        # the pole, UT1 and UT1's slope of one lookup: the epochs and those ut1_rate differences,
        # in one array (every step of the lookup is elementwise: the values are the separate
        # lookups' to the bit)
        both, ut1_tai = _eop_and_ut1_tai(np.concatenate((flat, *_rate_epochs(t))))
        eop, rate = both[:n], _ut1_rate_from(ut1_tai[n:], t)
    W = _polar_motion(t, dut1_s, eop)
    r = np.matvec(W, np.asarray(r_itrs_km, dtype=float))
    theta = _era(t, dut1_s, eop)
    R = _r3_neg(theta)
    c, s = np.cos(theta), np.sin(theta)
    dR = np.zeros(np.shape(theta) + (3, 3))
    dR[..., 0, 0] = -s
    dR[..., 0, 1] = -c
    dR[..., 1, 0] = c
    dR[..., 1, 1] = -s
    omega = 2.0 * np.pi * ERA_RATE_CYCLES_PER_UT1_DAY / SECONDS_PER_DAY
    if dut1_s is None:  # UT1 runs slow by the length-of-day excess (~1e-8): the uploaded slope
        dR *= (omega * (1.0 + rate))[..., None, None]
    else:
        dR *= omega
    h = 3600.0  # Q varies over >= 5.5 days; a central difference over +-1 h is exact enough
    # Q at t, t + h and t − h from one (elementwise) evaluation of the precession-nutation model,
    # once per distinct epoch: on a grid of epochs a divisor of h apart (the stations' 10-minute
    # nodes) most t ± h are grid epochs themselves: a station's 24 nodes need the series at 36
    # epochs, not 72 (0.40 ms instead of 0.49 for the whole chain; each epoch's values are the
    # same to the bit)
    epochs, back = np.unique(np.concatenate((flat, flat + h, flat - h)), return_inverse=True)
    Qs = cirs_to_gcrs_matrix(epochs)[back]
    Q, Q_hi, Q_lo = (Qs[k * n:(k + 1) * n].reshape(t.shape + (3, 3)) for k in range(3))
    dQ = (Q_hi - Q_lo) / (2 * h)
    pos = ((Q @ R) @ r[..., None])[..., 0]
    vel = ((Q @ dR + dQ @ R) @ r[..., None])[..., 0]
    # the same product as itrs_to_gcrs_matrix, of the same factors
    return pos, vel, (Q @ R @ W)[..., :, 2] if pole else None


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

"""Time scales: UTC <-> TAI <-> TT <-> TDB, and Unix time.

The one time variable used everywhere in navbank is ``t_tdb``: seconds of TDB past J2000.0
(2000-01-01T12:00:00 TDB, "ephemeris seconds", the SPICE ET convention).

* TAI - UTC comes from the IERS leap-second table (10 s in 1972 ... 37 s since 2017-01-01).
  UTC before 1972 is not supported.
* TT = TAI + 32.184 s exactly.
* TDB - TT is the periodic term of USNO Circular 179 (Kaplan 2005) eq. 2.6, a truncation of the
  Fairhead & Bretagnon (1990) series; amplitude ~1.66 ms, error ~10 us.

Times written with a leap second (``...T23:59:60``) parse and format correctly. Unix time
follows POSIX: it does not count leap seconds (a leap second repeats the next Unix second).
"""

from __future__ import annotations

import math
import re
import numpy as np

from fsw.astro.constants import (
    SECONDS_PER_DAY,
    SECONDS_PER_JULIAN_CENTURY,
    TT_MINUS_TAI_S,
    UNIX_AT_J2000_UTC_NOON,
)


class TimeError(ValueError):
    """A time string or value cannot be converted (bad format, before 1972, not finite)."""


# (UTC date on which the new value starts, TAI - UTC [s]), IERS Bulletin C.
LEAP_SECONDS: tuple[tuple[tuple[int, int, int], int], ...] = (
    ((1972, 1, 1), 10), ((1972, 7, 1), 11), ((1973, 1, 1), 12), ((1974, 1, 1), 13),
    ((1975, 1, 1), 14), ((1976, 1, 1), 15), ((1977, 1, 1), 16), ((1978, 1, 1), 17),
    ((1979, 1, 1), 18), ((1980, 1, 1), 19), ((1981, 7, 1), 20), ((1982, 7, 1), 21),
    ((1983, 7, 1), 22), ((1985, 7, 1), 23), ((1988, 1, 1), 24), ((1990, 1, 1), 25),
    ((1991, 1, 1), 26), ((1992, 7, 1), 27), ((1993, 7, 1), 28), ((1994, 7, 1), 29),
    ((1996, 1, 1), 30), ((1997, 7, 1), 31), ((1999, 1, 1), 32), ((2006, 1, 1), 33),
    ((2009, 1, 1), 34), ((2012, 7, 1), 35), ((2015, 7, 1), 36), ((2017, 1, 1), 37),
)


def days_from_civil(year: int, month: int, day: int) -> int:
    """Days from 2000-01-01 to the given proleptic Gregorian date (H. Hinnant's algorithm)."""
    y = year - (1 if month <= 2 else 0)
    era = (y if y >= 0 else y - 399) // 400
    yoe = y - era * 400
    doy = (153 * (month + (-3 if month > 2 else 9)) + 2) // 5 + day - 1
    doe = yoe * 365 + yoe // 4 - yoe // 100 + doy
    return era * 146097 + doe - 719468 - 10957


def civil_from_days(days: int) -> tuple[int, int, int]:
    """Inverse of :func:`days_from_civil`."""
    z = days + 10957 + 719468
    era = (z if z >= 0 else z - 146096) // 146097
    doe = z - era * 146097
    yoe = (doe - doe // 1460 + doe // 36524 - doe // 146096) // 365
    y = yoe + era * 400
    doy = doe - (365 * yoe + yoe // 4 - yoe // 100)
    mp = (5 * doy + 2) // 153
    d = doy - (153 * mp + 2) // 5 + 1
    m = mp + (3 if mp < 10 else -9)
    return (y + (1 if m <= 2 else 0), m, d)


# "Naive" UTC seconds: calendar seconds from 2000-01-01T12:00:00 UTC counting 86400 s per day.
_LEAP_NAIVE = np.array([days_from_civil(*d) * SECONDS_PER_DAY - 43200.0 for d, _ in LEAP_SECONDS])
_LEAP_DAT = np.array([float(v) for _, v in LEAP_SECONDS])
# TAI (as seconds past 2000-01-01T12:00:00 on the TAI scale label) at which each value starts.
_LEAP_TAI = _LEAP_NAIVE + _LEAP_DAT


def _dat_from_naive_utc(u: np.ndarray) -> np.ndarray:
    idx = np.searchsorted(_LEAP_NAIVE, u, side="right") - 1
    if np.any(idx < 0):
        raise TimeError("UTC before 1972-01-01 is not supported")
    return _LEAP_DAT[idx]


def tdb_minus_tt(t_tt: np.ndarray | float) -> np.ndarray | float:
    """TDB - TT [s] at TT seconds past J2000 (USNO Circular 179 eq. 2.6)."""
    T = np.asarray(t_tt, dtype=float) / SECONDS_PER_JULIAN_CENTURY
    out = (
        0.001657 * np.sin(628.3076 * T + 6.2401)
        + 0.000022 * np.sin(575.3385 * T + 4.2970)
        + 0.000014 * np.sin(1256.6152 * T + 6.1969)
        + 0.000005 * np.sin(606.9777 * T + 4.0212)
        + 0.000005 * np.sin(52.9691 * T + 0.4444)
        + 0.000002 * np.sin(21.3299 * T + 5.5431)
        + 0.000010 * T * np.sin(628.3076 * T + 4.2490)
    )
    return float(out) if np.ndim(out) == 0 else out


def _num(x):
    """A float for scalars, a float array otherwise."""
    return np.asarray(x, dtype=float) if np.ndim(x) else float(x)


def tt_to_tdb(t_tt):
    """TT seconds past J2000 -> TDB seconds past J2000."""
    t_tt = _num(t_tt)
    _check_finite(np.asarray(t_tt))
    return t_tt + tdb_minus_tt(t_tt)


def tdb_to_tt(t_tdb):
    """TDB seconds past J2000 -> TT seconds past J2000 (fixed point; the term varies by < 1e-10 s/s)."""
    t_tdb = _num(t_tdb)
    _check_finite(np.asarray(t_tdb))
    t_tt = t_tdb - tdb_minus_tt(t_tdb)
    t_tt = t_tdb - tdb_minus_tt(t_tt)
    return t_tt


def tai_to_tt(t_tai):
    """TAI seconds past 2000-01-01T12:00:00 TAI -> TT seconds past J2000."""
    return t_tai + TT_MINUS_TAI_S


def tt_to_tai(t_tt):
    """Inverse of :func:`tai_to_tt`."""
    return t_tt - TT_MINUS_TAI_S


def naive_utc_to_tai(u):
    """Naive UTC seconds past 2000-01-01T12:00:00 UTC -> TAI seconds (vectorised)."""
    arr = np.asarray(u, dtype=float)
    _check_finite(arr)
    out = arr + _dat_from_naive_utc(arr)
    return float(out) if out.ndim == 0 else out


def tai_to_naive_utc(t_tai):
    """TAI seconds -> naive UTC seconds. During a leap second it returns the next midnight."""
    arr = np.asarray(t_tai, dtype=float)
    _check_finite(arr)
    idx = np.searchsorted(_LEAP_TAI, arr, side="right") - 1
    if np.any(idx < 0):
        raise TimeError("UTC before 1972-01-01 is not supported")
    out = arr - _LEAP_DAT[idx]
    return float(out) if out.ndim == 0 else out


def _check_finite(arr: np.ndarray) -> None:
    if not np.all(np.isfinite(arr)):
        raise TimeError("time value is not finite")


def naive_utc_to_tdb(u):
    """Naive UTC seconds past 2000-01-01T12:00:00 UTC -> t_tdb."""
    return tt_to_tdb(tai_to_tt(naive_utc_to_tai(u)))


def tdb_to_naive_utc(t_tdb):
    """t_tdb -> naive UTC seconds past 2000-01-01T12:00:00 UTC (= UT1 count when UT1 ~ UTC)."""
    return tai_to_naive_utc(tt_to_tai(tdb_to_tt(t_tdb)))


def tdb_to_unix(t_tdb):
    """t_tdb -> Unix seconds of the corresponding UTC (POSIX, no leap seconds). Vectorised."""
    return tdb_to_naive_utc(t_tdb) + UNIX_AT_J2000_UTC_NOON


def unix_to_tdb(unix_s):
    """Unix seconds (UTC) -> t_tdb. Vectorised."""
    return naive_utc_to_tdb(_num(unix_s) - UNIX_AT_J2000_UTC_NOON)


def tdb_to_jd(t_tdb):
    """t_tdb -> Julian Date on the TDB scale (loses ~20 us of resolution; prefer t_tdb)."""
    return 2451545.0 + _num(t_tdb) / SECONDS_PER_DAY


_ISO_RE = re.compile(
    r"^\s*(\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2})(\.\d*)?)?)?\s*(Z|\+00:?00)?\s*$"
)


def parse_iso(s: str) -> tuple[int, int, int, int, int, int, float]:
    """Split an ISO 8601 UTC string into (Y, M, D, h, m, s, fraction); validates the fields."""
    if not isinstance(s, str):
        raise TimeError(f"expected an ISO 8601 string, got {type(s).__name__}")
    m = _ISO_RE.match(s)
    if not m:
        raise TimeError(f"not an ISO 8601 UTC time: {s!r} (expected YYYY-MM-DDThh:mm:ss[.fff][Z])")
    y, mo, d = int(m.group(1)), int(m.group(2)), int(m.group(3))
    hh = int(m.group(4) or 0)
    mm = int(m.group(5) or 0)
    ss = int(m.group(6) or 0)
    frac = float(m.group(7)) if m.group(7) and len(m.group(7)) > 1 else 0.0
    if not (1 <= mo <= 12) or not (1 <= d <= 31) or civil_from_days(days_from_civil(y, mo, d)) != (y, mo, d):
        raise TimeError(f"invalid calendar date in {s!r}")
    if hh > 23 or mm > 59 or ss > 60:
        raise TimeError(f"invalid time of day in {s!r}")
    if ss == 60:
        next_day = civil_from_days(days_from_civil(y, mo, d) + 1)
        if (hh, mm) != (23, 59) or next_day not in {day for day, _ in LEAP_SECONDS}:
            raise TimeError(f"{s!r}: second 60 exists only at 23:59 before a leap second")
    return y, mo, d, hh, mm, ss, frac


def utc_iso_to_naive(s: str) -> float:
    """ISO 8601 UTC string -> naive UTC seconds past 2000-01-01T12:00:00 UTC."""
    y, mo, d, hh, mm, ss, frac = parse_iso(s)
    return days_from_civil(y, mo, d) * SECONDS_PER_DAY - 43200.0 + hh * 3600 + mm * 60 + ss + frac


def utc_iso_to_tdb(s: str) -> float:
    """ISO 8601 UTC string (e.g. ``"2018-11-26T19:47:00"``) -> t_tdb [s past J2000 TDB]."""
    y, mo, d, hh, mm, ss, frac = parse_iso(s)
    day_start = days_from_civil(y, mo, d) * SECONDS_PER_DAY - 43200.0
    # TAI-UTC in force during the stated day; a :60 second belongs to the day before the step.
    tai = day_start + _dat_from_naive_utc(np.asarray(day_start)) + hh * 3600 + mm * 60 + ss + frac
    return float(tt_to_tdb(tai_to_tt(float(tai))))


def tdb_to_utc_iso(t_tdb: float, digits: int = 3) -> str:
    """t_tdb -> ISO 8601 UTC string with ``digits`` decimals of seconds (leap seconds shown as :60)."""
    if np.ndim(t_tdb) != 0:
        raise TimeError("tdb_to_utc_iso takes one scalar time")
    t_tdb = float(t_tdb)
    if not math.isfinite(t_tdb):
        raise TimeError("time value is not finite")
    tai = float(tt_to_tai(tdb_to_tt(t_tdb)))
    idx = int(np.searchsorted(_LEAP_TAI, tai, side="right") - 1)
    if idx < 0:
        raise TimeError("UTC before 1972-01-01 is not supported")
    leap = False
    u = tai - _LEAP_DAT[idx]
    if idx + 1 < len(_LEAP_TAI) and tai >= _LEAP_TAI[idx + 1] - 1.0:
        leap = True  # inside the inserted second 23:59:60 before the next step
    scale = 10**digits
    total = round((u + 43200.0) * scale)  # ticks since 2000-01-01T00:00:00
    day, rem = divmod(total, 86400 * scale)
    if leap:
        day, rem = divmod(total - 86400 * scale, 86400 * scale)
        rem += 86400 * scale  # second 86400 of the previous day = 23:59:60
    y, mo, d = civil_from_days(int(day))
    secs, sub = divmod(rem, scale)
    hh, r = divmod(secs, 3600)
    mm, ss = divmod(r, 60)
    if leap:
        hh, mm, ss = 23, 59, 60
    text = f"{y:04d}-{mo:02d}-{d:02d}T{hh:02d}:{mm:02d}:{ss:02d}"
    if digits > 0:
        text += f".{sub:0{digits}d}"
    return text


def tdb_to_tt_centuries(t_tdb):
    """Julian centuries of TT past J2000 (the argument of precession-nutation series)."""
    return tdb_to_tt(t_tdb) / SECONDS_PER_JULIAN_CENTURY

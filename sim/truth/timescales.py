"""Truth time scales through ERFA: UTC <-> TAI <-> TT <-> TDB, UT1 and Unix time.

``t_tdb`` (seconds of TDB past J2000.0) is the simulator's independent variable, as everywhere in
navbank. TAI-UTC is ERFA's leap-second table (``eraDat``), TT = TAI + 32.184 s, and TDB-TT is
ERFA's ``eraDtdb``, the full Fairhead & Bretagnon (1990) series (787 terms, ~ns at the geocentre;
the topocentric terms, < 2 us, are left out because the time argument is geocentric). UT1 comes
from the IERS EOP C04 UT1-UTC series (:mod:`sim.truth.eop`).
"""

from __future__ import annotations

import math
import re

import erfa
import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY, TT_MINUS_TAI_S

JD_J2000 = 2451545.0
_UNIX_AT_J2000_UTC_NOON = 946728000.0  # 2000-01-01T12:00:00 UTC in POSIX seconds


class TruthTimeError(ValueError):
    """A time that the truth time scales cannot convert (bad text, non-finite, outside ERFA's range)."""


def _finite(t) -> np.ndarray:
    arr = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise TruthTimeError("time value is not finite")
    return arr


def _out(x: np.ndarray):
    return float(x) if np.ndim(x) == 0 else x


def tdb_minus_tt(t_tdb):
    """TDB - TT [s] at the geocentre (ERFA ``dtdb``, Fairhead & Bretagnon 1990)."""
    t = _finite(t_tdb)
    return _out(np.asarray(erfa.dtdb(JD_J2000, t / SECONDS_PER_DAY, 0.0, 0.0, 0.0, 0.0)))


# Exact-result shortcut for many epochs (see _tdb_to_tt_many): ERFA's series costs ~10 us an
# epoch; a cubic through hourly values of it errs < 1e-15 s (a test holds it to 1e-13 s over
# decades), so a bound of 1e-11 s leaves four orders of margin.
_NODE_S = 3600.0
_BOUND_S = 1e-11
_MIN_EPOCHS = 2000  # below this the exact series is cheaper than the nodes


def _tdb_to_tt_many(t: np.ndarray) -> np.ndarray:
    """``t - dtdb(t)`` bit for bit as the direct ERFA evaluation, at a fraction of its cost.

    An hourly cubic gives d~ with |d~ - dtdb| <= B. Rounding is monotone, so fl(t - dtdb) lies
    between fl(t - (d~ + B)) and fl(t - (d~ - B)); where those two agree (all but ~2B/ulp(t),
    ~0.02 % of epochs near 2020) the result *is* that value; elsewhere ERFA is evaluated exactly.
    """
    k0 = math.floor(float(t.min()) / _NODE_S) - 1
    n = math.floor(float(t.max()) / _NODE_S) + 3 - k0
    t_nodes = (k0 + np.arange(n)) * _NODE_S
    nodes = np.asarray(erfa.dtdb(JD_J2000, t_nodes / SECONDS_PER_DAY, 0.0, 0.0, 0.0, 0.0))
    x = t / _NODE_S - k0
    k = np.clip(np.floor(x).astype(np.int64), 1, n - 3)
    u = x - k
    p0, p1, p2, p3 = nodes[k - 1], nodes[k], nodes[k + 1], nodes[k + 2]
    d = (-u * (u - 1) * (u - 2) / 6 * p0 + (u + 1) * (u - 1) * (u - 2) / 2 * p1
         - (u + 1) * u * (u - 2) / 2 * p2 + (u + 1) * u * (u - 1) / 6 * p3)
    lo = t - (d + _BOUND_S)
    out = t - (d - _BOUND_S)
    near = lo != out
    if near.any():
        tn = t[near]
        out[near] = tn - np.asarray(erfa.dtdb(JD_J2000, tn / SECONDS_PER_DAY, 0.0, 0.0, 0.0, 0.0))
    return out


def tdb_to_tt(t_tdb):
    """TT seconds past J2000 (evaluating TDB-TT at TDB instead of TT errs < 1e-13 s)."""
    t = _finite(t_tdb)
    if t.ndim == 1 and t.size >= _MIN_EPOCHS and (float(t.max()) - float(t.min())) / _NODE_S < t.size / 4:
        return _tdb_to_tt_many(t)
    return _out(t - np.asarray(tdb_minus_tt(t)))


def tdb_to_tai(t_tdb):
    """TAI seconds past 2000-01-01T12:00:00 TAI."""
    return _out(np.asarray(tdb_to_tt(t_tdb)) - TT_MINUS_TAI_S)


def tdb_to_unix(t_tdb):
    """POSIX seconds of the UTC of t_tdb (ERFA ``taiutc`` and ``d2dtf``; 23:59:60 repeats the next second)."""
    tai = np.asarray(tdb_to_tai(t_tdb))
    u1, u2 = erfa.taiutc(JD_J2000, tai / SECONDS_PER_DAY)
    # calendar fields, not the quasi-JD: on a day with a leap second the JD fraction is stretched
    y, mo, d, hmsf = erfa.d2dtf("UTC", 9, u1, u2)
    _, mjd = erfa.cal2jd(y, mo, d)
    unix = ((np.asarray(mjd) - 40587.0) * SECONDS_PER_DAY + hmsf["h"] * 3600.0 + hmsf["m"] * 60.0 + hmsf["s"]
            + hmsf["f"] * 1e-9)
    return _out(np.asarray(unix, dtype=float))


_ISO = re.compile(r"^\s*(\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2}(?:\.\d*)?))?)?\s*(?:Z|\+00:?00)?\s*$")


def utc_iso_to_tdb(text: str) -> float:
    """ISO 8601 UTC text (``2018-11-26T19:47:00``, seconds up to 60.999 in a leap second) -> t_tdb."""
    m = _ISO.match(text) if isinstance(text, str) else None
    if m is None:
        raise TruthTimeError(f"not an ISO 8601 UTC time: {text!r}")
    y, mo, d = int(m.group(1)), int(m.group(2)), int(m.group(3))
    hh, mm = int(m.group(4) or 0), int(m.group(5) or 0)
    ss = float(m.group(6) or 0.0)
    try:
        u1, u2 = erfa.dtf2d("UTC", y, mo, d, hh, mm, ss)
        a1, a2 = erfa.utctai(u1, u2)
    except (erfa.ErfaError, ValueError) as exc:
        raise TruthTimeError(f"invalid UTC time {text!r}: {exc}") from None
    tai = (float(a1) - JD_J2000 + float(a2)) * SECONDS_PER_DAY
    tt = tai + TT_MINUS_TAI_S
    # TDB = TT + (TDB-TT)(TT); one fixed-point pass is exact to < 1e-13 s.
    return float(tt + float(erfa.dtdb(JD_J2000, tt / SECONDS_PER_DAY, 0.0, 0.0, 0.0, 0.0)))


def tai_minus_utc(year: int, month: int, day: int) -> float:
    """TAI-UTC [s] in force on a UTC date (ERFA ``dat``)."""
    return float(erfa.dat(year, month, day, 0.0))

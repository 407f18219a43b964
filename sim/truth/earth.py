"""Truth Earth orientation: ITRS -> GCRS by the IAU 2006/2000A CIO-based chain of ERFA.

``r_GCRS = Q(t) R3(-ERA) W(t) r_ITRS`` (IERS Conventions 2010 eq. 5.1) with

* Q from the CIP coordinates X, Y and the CIO locator s of ``eraXys06a`` (IAU 2006 precession,
  IAU 2000A nutation, 1365 terms) plus the observed celestial pole offsets dX, dY of the C04
  series, turned into a matrix by ``eraC2ixys``;
* ERA from UT1 (``eraEra00``), UT1 from TAI and the C04 UT1-TAI (:mod:`sim.truth.eop`);
* W from the C04 pole coordinates and the TIO locator s' (``eraPom00``, ``eraSp00``).

Cost: the full series is ~20 us an epoch and ERFA has no shortcut for arrays, so X, Y, s and
TDB-TT are evaluated on an hourly grid over the span a :class:`EarthOrientation` is made for and
interpolated (4-point Lagrange); everything fast (ERA, the pole, the matrices) is evaluated at
each epoch. The interpolation errs < 1e-12 rad in X, Y (< 0.01 mm at the surface; a test holds
it to ERFA's ``c2t06a`` evaluated directly). Holding a stale Q instead would cost 8.9 cm after
an hour, and the equinox-based matrix with ERA would cost 21.9 km, which is why neither is done.

The velocity is ``Q dR/dt W r`` + ``dQ/dt R W r`` (the second from the interpolant's slope), with
the ERA rate slowed by the UT1-TAI slope (the excess length of day, ~1 ms/day, 4e-9 km/s at the
surface); the pole's rate (~2 mas/day, < 1e-9 km/s) is left out.
"""

from __future__ import annotations

import math
from functools import lru_cache

import erfa
import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY, TT_MINUS_TAI_S
from sim.truth.eop import eop_at_tai
from sim.truth.timescales import JD_J2000

_NODE_S = 3600.0
_ERA_RATE = 2.0 * math.pi * 1.00273781191135448 / SECONDS_PER_DAY  # rad per UT1 second (IAU 2000 B1.8)


class EarthOrientationError(ValueError):
    """A time outside the span the orientation was prepared for, or a non-finite time."""


def _lagrange4(nodes: np.ndarray, k: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Value and slope (per node step) of the cubic through nodes k-1..k+2 at k + u, 0 <= u < 1."""
    p0, p1, p2, p3 = (nodes[k + j] for j in (-1, 0, 1, 2))
    u = u[:, None]
    w0 = -u * (u - 1) * (u - 2) / 6
    w1 = (u + 1) * (u - 1) * (u - 2) / 2
    w2 = -(u + 1) * u * (u - 2) / 2
    w3 = (u + 1) * u * (u - 1) / 6
    d0 = -(3 * u * u - 6 * u + 2) / 6
    d1 = (3 * u * u - 4 * u - 1) / 2
    d2 = -(3 * u * u - 2 * u - 2) / 2
    d3 = (3 * u * u - 1) / 6
    return w0 * p0 + w1 * p1 + w2 * p2 + w3 * p3, d0 * p0 + d1 * p1 + d2 * p2 + d3 * p3


def _r3(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R3(-theta) (turns a vector by +theta) and its derivative with respect to theta."""
    c, s = np.cos(theta), np.sin(theta)
    m = np.zeros(theta.shape + (3, 3))
    d = np.zeros(theta.shape + (3, 3))
    m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1], m[:, 2, 2] = c, -s, s, c, 1.0
    d[:, 0, 0], d[:, 0, 1], d[:, 1, 0], d[:, 1, 1] = -s, -c, c, -s
    return m, d


@lru_cache(maxsize=8)
def _node_table(k0: int, n: int) -> np.ndarray:
    """X, Y, s and TDB-TT at the hourly nodes k0 .. k0+n-1 (read-only; every run of a scenario
    flies the same span, so a campaign pays the ~50 ms of the full series once per process)."""
    t_nodes = (k0 + np.arange(n)) * _NODE_S
    dtdb = erfa.dtdb(JD_J2000, t_nodes / SECONDS_PER_DAY, 0.0, 0.0, 0.0, 0.0)
    tt = t_nodes - dtdb
    x, y, s = erfa.xys06a(JD_J2000, tt / SECONDS_PER_DAY)
    # columns: X, Y, s, TDB-TT at each node (s and TDB-TT are smooth enough for the same cubic)
    nodes = np.column_stack([x, y, s, dtdb])
    nodes.flags.writeable = False
    return nodes


class EarthOrientation:
    """ITRS -> GCRS over [t_start, t_end] (TDB seconds past J2000)."""

    def __init__(self, t_start: float, t_end: float) -> None:
        if not (math.isfinite(t_start) and math.isfinite(t_end) and t_end >= t_start):
            raise EarthOrientationError("span must be finite with t_end >= t_start")
        self.k0 = math.floor(t_start / _NODE_S) - 2
        n = math.ceil(t_end / _NODE_S) + 3 - self.k0
        t_nodes = (self.k0 + np.arange(n)) * _NODE_S
        self.t_first, self.t_last = float(t_nodes[1]), float(t_nodes[-3])
        self._nodes = _node_table(self.k0, n)

    def _interp(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not np.all(np.isfinite(t)):
            raise EarthOrientationError("non-finite time")
        if t.size and (t.min() < self.t_first or t.max() > self.t_last):
            raise EarthOrientationError(
                f"time outside the Earth orientation span [{self.t_first:.0f}, {self.t_last:.0f}] s")
        x = t / _NODE_S - self.k0
        k = np.floor(x).astype(np.int64)
        val, slope = _lagrange4(self._nodes, k, x - k)
        return val, slope / _NODE_S

    def rotation(self, t_tdb) -> np.ndarray:
        """ITRS -> GCRS rotation M (N, 3, 3) at t (N,): :meth:`matrices` without the rate."""
        return self.matrices(t_tdb, rate=False)[0]

    def matrices(self, t_tdb, rate: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """ITRS -> GCRS rotation M (N, 3, 3) and its time derivative dM/dt at t (N,) (zeros
        when ``rate`` is False)."""
        t = np.atleast_1d(np.asarray(t_tdb, dtype=float))
        val, slope = self._interp(t)
        tt = t - val[:, 3]
        tai = tt - TT_MINUS_TAI_S
        eop = eop_at_tai(tai)
        X, Y, s = val[:, 0] + eop.dx, val[:, 1] + eop.dy, val[:, 2]
        q = np.swapaxes(erfa.c2ixys(X, Y, s), -1, -2)  # CIRS -> GCRS
        ut1 = tai + eop.ut1_minus_tai
        day = np.floor(ut1 / SECONDS_PER_DAY)  # whole days apart keep the fraction's resolution (1e-11 s)
        era = np.asarray(erfa.era00(JD_J2000 + day, (ut1 - day * SECONDS_PER_DAY) / SECONDS_PER_DAY))
        r, dr = _r3(era)
        w = np.swapaxes(erfa.pom00(eop.xp, eop.yp, erfa.sp00(JD_J2000, tt / SECONDS_PER_DAY)), -1, -2)  # ITRS -> TIRS
        m = q @ r @ w
        if not rate:
            return m, np.zeros_like(m)
        h = 60.0  # the slope of Q from the cubic's slope: one minute each side is linear to 1e-16
        q_p = np.swapaxes(erfa.c2ixys(X + h * slope[:, 0], Y + h * slope[:, 1], s + h * slope[:, 2]), -1, -2)
        q_m = np.swapaxes(erfa.c2ixys(X - h * slope[:, 0], Y - h * slope[:, 1], s - h * slope[:, 2]), -1, -2)
        dq = (q_p - q_m) / (2 * h)
        dm = q @ (dr * (_ERA_RATE * (1.0 + eop.ut1_rate))[:, None, None]) @ w + dq @ r @ w
        return m, dm

    def state(self, r_itrs_km, t_tdb) -> tuple[np.ndarray, np.ndarray]:
        """GCRS position [km] and velocity [km/s] of a point fixed in the ITRS; (N, 3) each."""
        m, dm = self.matrices(t_tdb)
        r = np.asarray(r_itrs_km, dtype=float)
        return m @ r, dm @ r


def itrs_to_gcrs_direct(t_tdb: float, pole_offsets: bool = True) -> np.ndarray:
    """One epoch without interpolation: ERFA's full series at t itself, the reference for tests.

    With ``pole_offsets`` False this is exactly ERFA's ``c2t06a`` with the C04 UT1 and pole."""
    dtdb = float(erfa.dtdb(JD_J2000, t_tdb / SECONDS_PER_DAY, 0.0, 0.0, 0.0, 0.0))
    tt = t_tdb - dtdb
    tai = tt - TT_MINUS_TAI_S
    e = eop_at_tai(tai)
    ut1 = tai + float(e.ut1_minus_tai[0])
    if not pole_offsets:
        rc2t = erfa.c2t06a(JD_J2000, tt / SECONDS_PER_DAY, JD_J2000, ut1 / SECONDS_PER_DAY, float(e.xp[0]),
                           float(e.yp[0]))
        return np.asarray(rc2t).T
    x, y, s = erfa.xys06a(JD_J2000, tt / SECONDS_PER_DAY)
    rc2i = erfa.c2ixys(x + float(e.dx[0]), y + float(e.dy[0]), s)
    rpom = erfa.pom00(float(e.xp[0]), float(e.yp[0]), erfa.sp00(JD_J2000, tt / SECONDS_PER_DAY))
    era = erfa.era00(JD_J2000, ut1 / SECONDS_PER_DAY)
    return np.asarray(erfa.c2tcio(rc2i, era, rpom)).T

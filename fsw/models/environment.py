"""What the onboard models know of the solar system: planets, DSN stations and Mars' moons.

Positions are in ICRF axes. Planets come from DE421 through an interpolating table centred on
the solar-system barycentre (SSB), because the radiometric and optical light-time equations
are solved in the barycentric frame (as the measurements are made); the dynamics take
Mars-centred differences of the same table. Phobos and Deimos are the Keplerian orbits of
:mod:`fsw.astro.moons`.

DSN stations: the Earth-rotation chain of :mod:`fsw.astro.stations` costs ~0.15 ms a call, so
the geocentric station state is evaluated on a 300 s grid (cached) together with the celestial
intermediate pole k (third column of the ITRS→GCRS matrix), and carried to the requested time
by the rotation about k by ω⊕Δt (Rodrigues) — the motion of a point fixed on the rotating
Earth. Over |Δt| ≤ 150 s the neglected precession–nutation motion of the pole moves a station
by < 1e-7 km. The result is an explicit smooth function of t whose velocity is its exact
derivative, which the measurement partials rely on.

Planet states at one time come from the table's position interpolant (5 µs) with the velocity
as a ±0.5 s central difference of it (error < 1e-12 km/s), ~3× cheaper than its state call.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from fsw.astro.constants import OMEGA_EARTH_RAD_S, SECONDS_PER_DAY
from fsw.astro.ephemeris import Ephemeris, EphemerisTable, default_ephemeris
from fsw.astro.moons import MOONS, moon_state
from fsw.astro.earth import itrs_to_gcrs_matrix
from fsw.astro.stations import StationError, station, station_state_icrf
from fsw.models.vector import cross

#: Bodies of the table, in row order.
TABLE_BODIES: tuple[str, ...] = ("sun", "emb", "jupiter", "earth", "mars")
SUN, EMB, JUPITER, EARTH, MARS = range(5)
#: Optical targets the onboard camera model knows.
OPTICAL_TARGETS: tuple[str, ...] = ("mars", *MOONS)

_STATION_GRID_S = 300.0


class Environment:
    """Onboard ephemeris access with lazily built interpolation tables."""

    def __init__(self, ephemeris: Ephemeris | None = None, table_span_days: float = 60.0, table_step_s: float = 1800.0):
        self._eph = ephemeris
        self._span = table_span_days * SECONDS_PER_DAY
        self._step = table_step_s
        self._table: EphemerisTable | None = None
        self._stations: OrderedDict[tuple[str, float], tuple[np.ndarray, np.ndarray]] = OrderedDict()

    # -- planets --------------------------------------------------------------------------------
    def _table_for(self, t_lo: float, t_hi: float) -> EphemerisTable:
        tab = self._table
        if tab is None or t_lo < tab.t_first + 3 * self._step or t_hi > tab.t_last - 3 * self._step:
            eph = self._eph if self._eph is not None else default_ephemeris()
            start = t_lo - 2.0 * SECONDS_PER_DAY
            tab = EphemerisTable(eph, start, max(t_hi, start + self._span), TABLE_BODIES, "ssb", self._step)
            self._table = tab
        return tab

    def positions_ssb(self, t: float) -> np.ndarray:
        """(5, 3) SSB positions of TABLE_BODIES at one time [km]."""
        return self._table_for(t, t).positions(t)

    def states_ssb(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """SSB positions and velocities (5, 3) of TABLE_BODIES at one time."""
        t = float(t)
        tab = self._table_for(t - 1.0, t + 1.0)
        return tab.positions(t), tab.positions(t + 0.5) - tab.positions(t - 0.5)

    def third_bodies(self, t: float) -> np.ndarray:
        """(3, 3) Mars-centred positions of the Sun, the Earth-Moon barycentre and Jupiter [km]."""
        p = self.positions_ssb(t)
        return p[:3] - p[MARS]

    # -- stations -----------------------------------------------------------------------------
    @staticmethod
    def check_station(name: str) -> str:
        """Canonical station name; raises ``StationError`` for an unknown one."""
        return station(name).name

    def _station_node(self, name: str, t_grid: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        key = (name, t_grid)
        hit = self._stations.get(key)
        if hit is None:
            r0, v0 = station_state_icrf(name, t_grid)
            hit = (r0, v0, itrs_to_gcrs_matrix(t_grid)[:, 2])
            self._stations[key] = hit
            if len(self._stations) > 256:
                self._stations.popitem(last=False)
        return hit

    def station_gcrs(self, name: str, t: np.ndarray, t_ref: float) -> tuple[np.ndarray, np.ndarray]:
        """Geocentric position and velocity of a station at times ``t_ref + t`` (offsets (k,))."""
        t_grid = round(t_ref / _STATION_GRID_S) * _STATION_GRID_S
        r0, v0, k = self._station_node(name, t_grid)
        dt = ((t_ref - t_grid) + np.asarray(t, dtype=float))[..., None]
        theta = OMEGA_EARTH_RAD_S * dt
        # what the rotation about k does not explain (pole motion, rate terms, ~1e-8 km/s)
        # is carried as a constant velocity
        dv = v0 - OMEGA_EARTH_RAD_S * cross(k, r0)
        c, s = np.cos(theta), np.sin(theta)

        def rotate(x: np.ndarray) -> np.ndarray:
            return x * c + cross(k, x) * s + k * float(k @ x) * (1.0 - c)

        r = rotate(r0)
        return r + dv * dt, OMEGA_EARTH_RAD_S * cross(k, r) + dv  # exact rate of the position

    # -- optical targets ----------------------------------------------------------------------
    @staticmethod
    def target_state(name: str, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Mars-centred position and velocity of an optical target."""
        if name == "mars":
            return np.zeros(3), np.zeros(3)
        return moon_state(name, t)


__all__ = ["Environment", "OPTICAL_TARGETS", "StationError", "TABLE_BODIES"]

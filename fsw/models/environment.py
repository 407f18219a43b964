"""What the onboard models know of the solar system: planets, DSN stations and Mars' moons.

Positions are in ICRF axes. Planets come from DE421 through an interpolating table centred on
the solar-system barycentre (SSB), because the radiometric and optical light-time equations
are solved in the barycentric frame (as the measurements are made); the dynamics take
Mars-centred differences of the same table. Phobos and Deimos are the uploaded precessing mean
elements of :mod:`fsw.astro.moons`; the asteroid beacons the heliocentric two-body orbits of the onboard
catalogue :mod:`fsw.astro.asteroids`, made Mars-centred with the table's Sun and Mars.

DSN stations: the Earth-rotation chain of :mod:`fsw.astro.stations` costs ~0.5 ms a node, so
the geocentric station state is evaluated on a 600 s grid (cached) together with the celestial
intermediate pole k (third column of the ITRS→GCRS matrix), and carried to the requested time
by the rotation about k by ω⊕Δt (Rodrigues) — the motion of a point fixed on the rotating
Earth — plus the node's remaining velocity (the pole's precession–nutation rate, ~1e-8 km/s).
What that leaves out grows as Δt²: < 3e-7 km at |Δt| ≤ 360 s (a range error 3000× below its
noise; both ends of a Doppler count use one node, where it changes the count by < 2e-9 km/s,
2 % of its noise). The result is an explicit smooth function of t whose velocity is its exact
derivative, which the measurement partials rely on.

Planet states come from the table's cubic Hermite interpolant and its exact derivative, evaluated
for all epochs of a measurement in one batched product (:meth:`Environment.states_many`).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Iterable
from typing import Any

import numpy as np

from fsw.astro.constants import OMEGA_EARTH_RAD_S, SECONDS_PER_DAY
from fsw.astro.ephemeris import Ephemeris, EphemerisError, EphemerisTable, default_ephemeris
from fsw.astro import asteroids
from fsw.astro.moons import MOONS, moon_state
from fsw.astro.stations import StationError, station, station_states_and_pole_icrf
from fsw.models.vector import cross

#: Bodies of the table, in row order.
TABLE_BODIES: tuple[str, ...] = ("sun", "emb", "jupiter", "earth", "mars")
SUN, EMB, JUPITER, EARTH, MARS = range(5)
#: Optical targets the onboard camera model knows: Mars, its moons and the beacon asteroids.
OPTICAL_TARGETS: tuple[str, ...] = ("mars", *MOONS, *asteroids.NAMES)

_STATION_GRID_S = 600.0
#: Station nodes evaluated together on a cache miss (four hours of a pass).
_STATION_PREFETCH = 24


class Environment:
    """Onboard ephemeris access with lazily built interpolation tables."""

    __slots__ = ("_eph", "_span", "_step", "_table", "_table_span", "_hermite", "_stations", "_station_arrays",
                 "_station_names", "_last_node")  # slotted: see fsw.executive.FrameExecutive

    def __init__(self, ephemeris: Ephemeris | None = None, table_span_days: float = 60.0, table_step_s: float = 1800.0):
        self._eph = ephemeris
        self._span = table_span_days * SECONDS_PER_DAY
        self._step = table_step_s
        self._table: EphemerisTable | None = None
        self._table_span: tuple[float, float] | None = None  # what the table was built over
        # replaced, with the table, before any lookup
        self._hermite: np.ndarray = np.empty((0, 4, 15))
        self._stations: OrderedDict[tuple[str, float], tuple[np.ndarray, ...]] = OrderedDict()
        self._station_arrays: dict[tuple[str, float], np.ndarray] = {}
        self._station_names: dict[str, str] = {}  # spellings seen -> canonical name
        self._last_node: tuple[float, str, np.ndarray] = (np.nan, "", np.empty((4, 3)))

    # A checkpoint (fsw.core.checkpoint) pickles the core every few hundred measurements. The
    # ephemeris table and its Hermite nodes are ~2 MB of it, and a pure function of the span
    # they were built over: the checkpoint carries the span, and a restore rebuilds the very
    # same table from it. The station cache (up to 256 nodes) travels as one (K, 4, 3) array
    # with its keys in cache order, not as a thousand small arrays.
    def _state(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in self.__slots__}

    def __getstate__(self) -> dict[str, Any]:
        state = self._state()
        state["_table"] = None
        state["_hermite"] = None
        keys = list(self._stations)
        state["_stations"] = keys
        state["_station_arrays"] = (np.stack([self._station_arrays[k] for k in keys]) if keys
                                    else np.empty((0, 4, 3)))
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        keys, nodes = state.pop("_stations"), state.pop("_station_arrays")
        for name, value in state.items():
            setattr(self, name, value)
        self._stations = OrderedDict()
        self._station_arrays = {}
        for key, node in zip(keys, nodes):
            self._stations[key] = (node[0], node[1], node[2], node[3])
            self._station_arrays[key] = node
        self._hermite = np.empty((0, 4, 15))
        if self._table_span is not None:
            self._build_table(*self._table_span)

    def __deepcopy__(self, memo: dict[int, Any]) -> Environment:
        """A copy in memory (the FSW's warm-up, the RQP adaptation's bank for every α it tries)
        shares what is only ever replaced, never written: the ephemeris reader, the table and its
        Hermite nodes, the station nodes (pure functions of the table's span and of station and
        epoch). Its caches are containers of its own holding the same nodes, so what either
        environment adds or evicts later is its own. Deep-copying the 256 cached nodes' arrays
        took 2.9 ms of the 3.2 ms a copy cost, and a copy of the bank 3.9 ms (now 0.9 ms):
        copied at the start of every RQP window inside a bank stage and for every α tried, in
        CPU budget mode they made the heaviest frames of an adaptation
        (``tests/test_models_environment.py`` holds the nodes to never being written)."""
        new = object.__new__(type(self))
        memo[id(self)] = new
        for name in self.__slots__:
            setattr(new, name, getattr(self, name))
        new._stations = OrderedDict(self._stations)
        new._station_arrays = dict(self._station_arrays)
        new._station_names = dict(self._station_names)
        return new

    # -- planets --------------------------------------------------------------------------------
    def _table_for(self, t_lo: float, t_hi: float) -> EphemerisTable:
        tab = self._table
        if tab is None or t_lo < tab.t_first + 3 * self._step or t_hi > tab.t_last - 3 * self._step:
            start = t_lo - 2.0 * SECONDS_PER_DAY
            tab = self._build_table(start, max(t_hi, start + self._span))
        return tab

    def _build_table(self, start: float, end: float) -> EphemerisTable:
        eph = self._eph if self._eph is not None else default_ephemeris()
        tab = EphemerisTable(eph, start, end, TABLE_BODIES, "ssb", self._step)
        self._table = tab
        self._table_span = (start, end)
        # the table's cubic Hermite interpolant per grid interval i, as the four node
        # vectors [p_i, h v_i, p_i+1, h v_i+1] (rows of 5 bodies × 3), for batched lookups
        n = int(round((tab.t_last - tab.t_first) / tab.step)) + 1
        p, v = tab.states(tab.t_first + tab.step * np.arange(n))
        nodes = np.empty((n - 1, 4, 15))
        nodes[:, 0] = p[:-1].reshape(n - 1, 15)
        nodes[:, 1] = tab.step * v[:-1].reshape(n - 1, 15)
        nodes[:, 2] = p[1:].reshape(n - 1, 15)
        nodes[:, 3] = tab.step * v[1:].reshape(n - 1, 15)
        self._hermite = nodes
        return tab

    def table_nodes(self, t_lo: float, t_hi: float) -> tuple[np.ndarray, np.ndarray, float, float]:
        """The table covering [t_lo, t_hi] as the compiled kernels read it: SSB positions and
        velocities at the nodes (n, 5, 3), the first node's epoch and the node step."""
        tab = self._table_for(t_lo, t_hi)
        p, v = tab.nodes
        return p, v, tab.t0, tab.step

    def positions_ssb(self, t: float) -> np.ndarray:
        """(5, 3) SSB positions of TABLE_BODIES at one time [km]."""
        return self._table_for(t, t).positions(t)

    def states_ssb(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """SSB positions and velocities (5, 3) of TABLE_BODIES at one time."""
        p, v = self.states_many((t,))
        return p[0], v[0]

    def states_many(self, t: Iterable[float]) -> tuple[np.ndarray, np.ndarray]:
        """SSB positions and velocities (K, 5, 3) of TABLE_BODIES at K times (a short sequence):
        the table's cubic Hermite interpolant and its exact derivative, all epochs in one
        batched product (the per-epoch basis is a few scalar operations)."""
        ts = [float(v) for v in t]
        tab = self._table_for(min(ts) - 1.0, max(ts) + 1.0)
        t_first, step = tab.t_first, tab.step
        rows = []
        idx = []
        for tk in ts:
            x = (tk - t_first) / step
            i = int(x)
            s = x - i
            s2 = s * s
            s3 = s2 * s
            d0 = (6.0 * s2 - 6.0 * s) / step
            rows.append(((2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, 3.0 * s2 - 2.0 * s3, s3 - s2),
                         (d0, (3.0 * s2 - 4.0 * s + 1.0) / step, -d0, (3.0 * s2 - 2.0 * s) / step)))
            idx.append(i)
        pv = np.matmul(np.array(rows), self._hermite[idx]).reshape(len(ts), 2, 5, 3)
        return pv[:, 0], pv[:, 1]

    def covers(self, t: float) -> bool:
        """Whether t lies inside the onboard ephemeris (the table is extended as needed)."""
        try:
            self._table_for(t - 1.0, t + 1.0)
        except EphemerisError:
            return False
        return True

    def third_bodies(self, t: float) -> np.ndarray:
        """(3, 3) Mars-centred positions of the Sun, the Earth-Moon barycentre and Jupiter [km]."""
        p = self.positions_ssb(t)
        return p[:3] - p[MARS]

    # -- stations -----------------------------------------------------------------------------
    def check_station(self, name: str) -> str:
        """Canonical station name; raises ``StationError`` for an unknown one."""
        known = self._station_names.get(name) if isinstance(name, str) else None
        if known is None:
            known = station(name).name
            if len(self._station_names) < 64:
                self._station_names[name] = known
        return known

    def _station_node(self, name: str, t_grid: float) -> tuple[np.ndarray, ...]:
        """(r0, k × r0, k (k·r0), dv) of a station at a grid epoch; k is the celestial pole.

        A miss evaluates the Earth-rotation chain for the next ``_STATION_PREFETCH`` nodes at
        once (one vectorised call costs little more than one node; a pass walks the grid
        forwards)."""
        key = (name, t_grid)
        hit = self._stations.get(key)
        if hit is None:
            grid = t_grid + _STATION_GRID_S * np.arange(_STATION_PREFETCH)
            r0, v0, k = station_states_and_pole_icrf(name, grid)
            kxr = cross(k, r0)
            kkr = k * np.vecdot(k, r0)[:, None]
            # what the rotation about k does not explain (pole motion, rate terms, ~1e-8 km/s)
            # is carried as a constant velocity
            dv = v0 - OMEGA_EARTH_RAD_S * kxr
            stacked = np.stack((r0, kxr, kkr, dv), axis=1)  # (prefetch, 4, 3): node j is stacked[j]
            for j, tj in enumerate(grid.tolist()):
                self._stations[(name, tj)] = (r0[j], kxr[j], kkr[j], dv[j])
                self._station_arrays[(name, tj)] = stacked[j]
            self._last_node = (np.nan, "", self._last_node[2])  # it may be evicted below
            while len(self._stations) > 256:
                evicted, _ = self._stations.popitem(last=False)
                self._station_arrays.pop(evicted, None)
            hit = self._stations[key]
        return hit

    def station_node(self, name: str, t_ref: float) -> tuple[np.ndarray, float]:
        """The station's grid node nearest t_ref as a (4, 3) array [r0, k × r0, k (k·r0), dv]
        and its epoch (what :meth:`station_gcrs` rotates; for the compiled light-time kernel)."""
        t_grid = round(t_ref / _STATION_GRID_S) * _STATION_GRID_S
        last = self._last_node
        if last[0] == t_grid and last[1] == name:
            return last[2], t_grid
        key = (name, t_grid)
        node = self._station_arrays.get(key)
        if node is None or key not in self._stations:
            self._station_node(name, t_grid)
            node = self._station_arrays[key]
        # a pass asks for the same node for ten minutes of measurements
        self._last_node = (t_grid, name, node)
        return node, t_grid

    def last_station_node(self, name: str) -> tuple[np.ndarray, float] | None:
        """The node :meth:`station_node` last returned and its epoch, if it was for ``name`` (the
        node it returns again for any t_ref nearest that epoch)."""
        t_grid, last, node = self._last_node
        return (node, t_grid) if last == name else None

    def hermite_window(self, t_lo: float, t_hi: float) -> tuple[np.ndarray, float, float, float, float]:
        """:meth:`hermite_nodes` and the span [lo, hi] inside which later lookups use the same
        table (outside it the table is rebuilt first)."""
        tab = self._table_for(t_lo, t_hi)
        return self._hermite, tab.t_first, tab.step, tab.t_first + 3 * self._step, tab.t_last - 3 * self._step

    def hermite_nodes(self, t_lo: float, t_hi: float) -> tuple[np.ndarray, float, float]:
        """The table's Hermite nodes (intervals, 4, 15) covering [t_lo, t_hi], its first epoch and
        step (what :meth:`states_many` multiplies; for the compiled light-time kernel)."""
        tab = self._table_for(t_lo, t_hi)
        return self._hermite, tab.t_first, tab.step

    def station_gcrs(self, name: str, t: np.ndarray, t_ref: float) -> tuple[np.ndarray, np.ndarray]:
        """Geocentric position and velocity of a station at times ``t_ref + t`` (offsets (k,)).

        Rodrigues: r(Δt) = r0 cos θ + (k × r0) sin θ + k (k·r0)(1 − cos θ) + dv Δt, θ = ω⊕ Δt,
        and its exact rate ω⊕ [(k × r0) cos θ + (k (k·r0) − r0) sin θ] + dv."""
        t_grid = round(t_ref / _STATION_GRID_S) * _STATION_GRID_S
        r0, kxr, kkr, dv = self._station_node(name, t_grid)
        dt = (t_ref - t_grid) + np.asarray(t, dtype=float)
        theta = OMEGA_EARTH_RAD_S * dt
        c = np.cos(theta)[:, None]
        s = np.sin(theta)[:, None]
        r = r0 * c + kxr * s + kkr * (1.0 - c) + dv * dt[:, None]
        v = OMEGA_EARTH_RAD_S * (kxr * c + (kkr - r0) * s) + dv
        return r, v

    # -- optical targets ----------------------------------------------------------------------
    def target_state(self, name: str, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Mars-centred position and velocity of an optical target."""
        if name == "mars":
            return np.zeros(3), np.zeros(3)
        if name in asteroids.BEACONS:
            r, v = asteroids.beacon_state(name, t)
            p, pv = self.states_ssb(t)
            return r + p[SUN] - p[MARS], v + pv[SUN] - pv[MARS]
        return moon_state(name, t)


__all__ = ["Environment", "OPTICAL_TARGETS", "StationError", "TABLE_BODIES"]

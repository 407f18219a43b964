"""Positions of everything a sensor looks at, in one inertial frame (solar-system barycentre).

The truth trajectory is Mars-centred; light-time problems are solved in the barycentric frame
(see :mod:`sim.sensors.lighttime`), so the scene adds Mars' barycentric position from a DE421
table. Axes are ICRF throughout; units km and s (TDB seconds past J2000). Stations, Earth
orientation and the moons are the simulator's own truth models (:mod:`sim.truth`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from fsw.astro.ephemeris import Ephemeris, default_ephemeris
from sim.truth.earth import EarthOrientation
from sim.truth.moons import moon_state
from sim.truth.stations import station as truth_station
from sim.sensors import asteroids

PositionFn = Callable[[np.ndarray], np.ndarray]

_MARGIN_S = 2 * 86400.0  # light times and Doppler counts reach before the first reception


class Scene:
    """Spacecraft, Sun, Earth, Mars, moons and DSN stations as barycentric position functions.

    ``sc_position(t)`` gives the Mars-centred spacecraft position (N, 3) at TDB times t (N,),
    e.g. the truth trajectory's dense output.
    """

    def __init__(self, sc_position: PositionFn, t_start: float, t_end: float, ephemeris: Ephemeris | None = None,
                 step_s: float = 1800.0) -> None:
        eph = ephemeris if ephemeris is not None else default_ephemeris()
        self._sc_position = sc_position
        self._table = eph.table(t_start - _MARGIN_S, t_end + _MARGIN_S, bodies=("mars", "earth", "sun"),
                                center="ssb", step_s=step_s)
        self._earth = EarthOrientation(t_start - _MARGIN_S, t_end + _MARGIN_S)

    def station_gcrs(self, name: str, t) -> tuple[np.ndarray, np.ndarray]:
        """Geocentric (GCRS) position [km] and velocity [km/s] (N, 3) of DSN station ``name``."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        p, v = self._earth.state(truth_station(name).itrs_km(t)[..., None], t)
        return p[..., 0], v[..., 0]

    def elevation(self, name: str, t, target_geocentric_km) -> np.ndarray:
        """Elevation [rad] (N,) of geocentric targets (N, 3) above the station's WGS84 horizon."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        st = truth_station(name)
        m = self._earth.rotation(t)
        pos = (m @ st.itrs_km(t)[..., None])[..., 0]
        up = m @ st.up_itrs(float(t[0])) if t.size else np.zeros((0, 3))
        los = np.asarray(target_geocentric_km, dtype=float) - pos
        sin_el = np.einsum("ni,ni->n", los, up) / np.linalg.norm(los, axis=-1)
        return np.arcsin(np.clip(sin_el, -1.0, 1.0))

    def body(self, name: str, t) -> np.ndarray:
        """Barycentric position of ``mars``, ``earth`` or ``sun`` at times t (N,) -> (N, 3)."""
        return self._table.position(name, np.asarray(t, dtype=float))

    def sc_mars(self, t) -> np.ndarray:
        """Mars-centred spacecraft position (N, 3)."""
        return np.asarray(self._sc_position(np.atleast_1d(np.asarray(t, dtype=float))), dtype=float)

    def sc(self, t) -> np.ndarray:
        """Barycentric spacecraft position (N, 3)."""
        t = np.asarray(t, dtype=float)
        return self.body("mars", t) + self.sc_mars(t)

    def body_velocity(self, name: str, t) -> np.ndarray:
        """Barycentric velocity of ``mars``, ``earth`` or ``sun`` at times t (N,) -> (N, 3)."""
        return self._table.state(name, np.asarray(t, dtype=float))[1]

    def station(self, name: str) -> Callable[[np.ndarray], np.ndarray]:
        """t -> barycentric position (N, 3) of DSN station ``name`` (Earth rotation included)."""

        def position(t: np.ndarray) -> np.ndarray:
            t = np.atleast_1d(np.asarray(t, dtype=float))
            # the rotation alone: the same product M r as station_gcrs' position, without the rate
            gcrs = (self._earth.rotation(t) @ truth_station(name).itrs_km(t)[..., None])[..., 0]
            return self.body("earth", t) + gcrs

        return position

    def station_velocity(self, name: str) -> Callable[[np.ndarray], np.ndarray]:
        """t -> barycentric velocity (N, 3) of DSN station ``name``."""

        def velocity(t: np.ndarray) -> np.ndarray:
            t = np.atleast_1d(np.asarray(t, dtype=float))
            return self.body_velocity("earth", t) + self.station_gcrs(name, t)[1]

        return velocity

    def station_state(self, name: str) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """t -> barycentric (position, velocity) (N, 3) each of DSN station ``name``: the values of
        :meth:`station` and :meth:`station_velocity`, from one Earth orientation and one ephemeris
        evaluation instead of two."""

        def state(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            t = np.atleast_1d(np.asarray(t, dtype=float))
            p_earth, v_earth = self._table.state("earth", t)
            p, v = self.station_gcrs(name, t)
            return p_earth + p, v_earth + v

        return state

    def target(self, name: str) -> Callable[[np.ndarray], np.ndarray]:
        """t -> barycentric position (N, 3) of an optical target: ``mars``, ``phobos``, ``deimos``
        or a beacon asteroid (:mod:`sim.sensors.asteroids`)."""
        if name == "mars":
            return lambda t: self.body("mars", np.atleast_1d(np.asarray(t, dtype=float)))
        if name in asteroids.BY_NAME:
            return lambda t: self.body("sun", np.atleast_1d(np.asarray(t, dtype=float))) + asteroids.heliocentric_state(name, t)[0]

        def position(t: np.ndarray) -> np.ndarray:
            t = np.atleast_1d(np.asarray(t, dtype=float))
            return self.body("mars", t) + moon_state(name, t)[0]

        return position

    def target_velocity(self, name: str) -> Callable[[np.ndarray], np.ndarray]:
        """t -> barycentric velocity (N, 3) of an optical target."""
        if name == "mars":
            return lambda t: self.body_velocity("mars", np.atleast_1d(np.asarray(t, dtype=float)))
        if name in asteroids.BY_NAME:
            return lambda t: self.body_velocity("sun", np.atleast_1d(np.asarray(t, dtype=float))) + asteroids.heliocentric_state(name, t)[1]

        def velocity(t: np.ndarray) -> np.ndarray:
            t = np.atleast_1d(np.asarray(t, dtype=float))
            return self.body_velocity("mars", t) + moon_state(name, t)[1]

        return velocity

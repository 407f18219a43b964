"""Positions of everything a sensor looks at, in one inertial frame (solar-system barycentre).

The truth trajectory is Mars-centred; light-time problems are solved in the barycentric frame
(see :mod:`sim.sensors.lighttime`), so the scene adds Mars' barycentric position from a DE421
table. Axes are ICRF throughout; units km and s (TDB seconds past J2000).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from fsw.astro.ephemeris import Ephemeris, default_ephemeris
from fsw.astro.moons import moon_state
from fsw.astro.stations import station_state_icrf
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
            return self.body("earth", t) + station_state_icrf(name, t)[0]

        return position

    def station_velocity(self, name: str) -> Callable[[np.ndarray], np.ndarray]:
        """t -> barycentric velocity (N, 3) of DSN station ``name``."""

        def velocity(t: np.ndarray) -> np.ndarray:
            t = np.atleast_1d(np.asarray(t, dtype=float))
            return self.body_velocity("earth", t) + station_state_icrf(name, t)[1]

        return velocity

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

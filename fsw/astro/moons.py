"""Phobos and Deimos: Mars-centred states from fixed Keplerian elements.

Elements are mean elements referred to the Mars equator of J2000 (IAU 2009 pole
``MARS_POLE_RA_DEG``/``MARS_POLE_DEC_DEG``); x of that frame is the ascending node of the Mars
equator on the ICRF equator. a, e, i are the values of DESIGN.md; the angles (node, argument
of periapsis, mean anomaly at J2000 TDB) are fixed reference values of this simulator, of the
kind published as mean elements but not a fit to observations. The mean motion follows from a and the
Mars-system GM, so positions and velocities are an exact two-body pair; the resulting
periods (7.655 h, 30.31 h) match DESIGN.md's 7.65 h and 30.3 h.

Simplifications, stated so nobody mistakes these for a satellite ephemeris: the J2-driven
precession of node and periapsis (Phobos' node regresses ~158 deg/yr) and the Laplace-plane
tilt are not modelled, so after months the angles differ from the real moons by tens of
degrees. Truth and onboard models both read this module, so the navigation problem stays
self-consistent; only comparison with real images would need a real satellite ephemeris.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import GM_MARS_SYSTEM
from fsw.astro.mars import MARS_EQUATOR_TO_ICRF


class MoonError(ValueError):
    """Unknown moon name or non-finite time."""


@dataclass(frozen=True)
class MoonElements:
    """Keplerian elements of a Mars moon in the Mars-equator J2000 frame (km, deg)."""

    a_km: float
    e: float
    i_deg: float
    node_deg: float
    argp_deg: float
    mean_anomaly_j2000_deg: float
    radius_km: float  # mean radius, for optical limb/centre-finding models

    @property
    def mean_motion(self) -> float:
        """rad/s, from a and GM of the Mars system."""
        return math.sqrt(GM_MARS_SYSTEM / self.a_km**3)

    @property
    def period_s(self) -> float:
        return 2.0 * math.pi / self.mean_motion


MOONS: dict[str, MoonElements] = {
    "phobos": MoonElements(9375.0, 0.0151, 1.08, 164.931, 150.247, 91.059, 11.08),
    "deimos": MoonElements(23463.0, 0.0003, 0.93, 339.600, 290.496, 296.230, 6.2),
}


def solve_kepler(mean_anomaly, e: float, tol: float = 1e-14) -> np.ndarray:
    """Eccentric anomaly E with E - e sin E = M (Newton, vectorised; e < 1)."""
    M = np.mod(np.asarray(mean_anomaly, dtype=float), 2 * np.pi)
    E = M + e * np.sin(M)
    for _ in range(30):
        dE = (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
        E = E - dE
        if np.all(np.abs(dE) < tol):
            break
    return E


def moon_state(name: str, t_tdb) -> tuple[np.ndarray, np.ndarray]:
    """Mars-centred ICRF position [km] and velocity [km/s] of ``phobos`` or ``deimos``.

    Scalar t -> (3,) arrays; t of shape (N,) -> (N, 3) arrays.
    """
    try:
        el = MOONS[name.lower()]
    except (KeyError, AttributeError):
        raise MoonError(f"unknown moon {name!r}; known: {', '.join(MOONS)}") from None
    t = np.asarray(t_tdb, dtype=float)
    if not np.all(np.isfinite(t)):
        raise MoonError("non-finite time")
    n = el.mean_motion
    E = solve_kepler(math.radians(el.mean_anomaly_j2000_deg) + n * t, el.e)
    cE, sE = np.cos(E), np.sin(E)
    b = el.a_km * math.sqrt(1.0 - el.e**2)
    # Perifocal coordinates (x towards periapsis).
    xp = el.a_km * (cE - el.e)
    yp = b * sE
    Edot = n / (1.0 - el.e * cE)
    vxp = -el.a_km * sE * Edot
    vyp = b * cE * Edot
    O, i, w = (math.radians(el.node_deg), math.radians(el.i_deg), math.radians(el.argp_deg))
    cO, sO, ci, si, cw, sw = math.cos(O), math.sin(O), math.cos(i), math.sin(i), math.cos(w), math.sin(w)
    # Perifocal -> Mars-equator frame: R3(-O) R1(-i) R3(-w), first two columns.
    P = np.array([cO * cw - sO * sw * ci, sO * cw + cO * sw * ci, sw * si])
    Q = np.array([-cO * sw - sO * cw * ci, -sO * sw + cO * cw * ci, cw * si])
    M = MARS_EQUATOR_TO_ICRF
    P, Q = M @ P, M @ Q
    pos = np.multiply.outer(xp, P) + np.multiply.outer(yp, Q)
    vel = np.multiply.outer(vxp, P) + np.multiply.outer(vyp, Q)
    return pos, vel

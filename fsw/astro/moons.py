"""Phobos and Deimos onboard: the uploaded mean elements, a precessing ellipse.

The onboard moon ephemeris is data a mission uploads, as the planetary ephemeris is: JPL's
published mean elements (Solar System Dynamics, "Planetary Satellite Mean Elements", MAR080
solution, epoch 1950 Jan 1.00 TT), each orbit referred to its own Laplace plane (pole RA/Dec
below; x is the plane's ascending node on the ICRF equator). Mean anomaly advances at the
published mean motion, the argument of periapsis advances and the node regresses at the
published precession periods.

Onboard simplifications: the epoch is taken as 1950 Jan 1.00 TDB (TDB-TT, 1.6 ms at most,
moves Phobos by < 4 m), and the velocity is that of the fixed ellipse of the instant (the
precession rates add < 2 m/s, which enter only the light-time correction, < 10 m at Mars
distances). The simulator evaluates the same published elements with its own code
(:mod:`sim.truth.moons`); docs/validation.md gives the measured difference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY
from fsw.astro.frames import pole_frame
from fsw.astro.mars import MARS_EQUATOR_TO_ICRF  # noqa: F401  (the Mars equator frame, re-exported)

_EPOCH_S = (2433282.5 - 2451545.0) * SECONDS_PER_DAY  # 1950 Jan 1.00, seconds past J2000
_YEAR_S = 365.25 * SECONDS_PER_DAY


class MoonError(ValueError):
    """Unknown moon name or non-finite time."""


@dataclass(frozen=True)
class MoonElements:
    """Published mean elements of a Mars moon (km, deg, deg/day, years) and its mean radius."""

    a_km: float
    e: float
    argp_deg: float
    mean_anomaly_deg: float
    i_deg: float
    node_deg: float
    n_deg_day: float
    p_argp_yr: float
    p_node_yr: float
    laplace_ra_deg: float
    laplace_dec_deg: float
    radius_km: float  # mean radius, for optical limb/centre-finding models

    @property
    def mean_motion(self) -> float:
        """rad/s."""
        return math.radians(self.n_deg_day) / SECONDS_PER_DAY

    @property
    def period_s(self) -> float:
        return 2.0 * math.pi / self.mean_motion


MOONS: dict[str, MoonElements] = {
    "phobos": MoonElements(9376.0, 0.0151, 150.057, 91.059, 1.075, 207.784, 1128.8447569, 1.1316, 2.2617,
                           317.671, 52.893, 11.08),
    "deimos": MoonElements(23458.0, 0.0002, 260.729, 325.329, 1.788, 24.525, 285.1618790, 27.3703, 54.5367,
                           316.657, 53.529, 6.2),
}
_FRAMES = {name: pole_frame(math.radians(el.laplace_ra_deg), math.radians(el.laplace_dec_deg))
           for name, el in MOONS.items()}


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
    if isinstance(t_tdb, float):
        return _moon_state_at(el, _FRAMES[name.lower()], t_tdb)
    t = np.asarray(t_tdb, dtype=float)
    if not np.all(np.isfinite(t)):
        raise MoonError("non-finite time")
    dt = t - _EPOCH_S
    n = el.mean_motion
    M = np.radians(np.mod(el.mean_anomaly_deg + el.n_deg_day * (dt / SECONDS_PER_DAY), 360.0))
    E = solve_kepler(M, el.e)
    cE, sE = np.cos(E), np.sin(E)
    b = el.a_km * math.sqrt(1.0 - el.e**2)
    xp = el.a_km * (cE - el.e)
    yp = b * sE
    Edot = n / (1.0 - el.e * cE)
    vxp = -el.a_km * sE * Edot
    vyp = b * cE * Edot
    w = np.radians(el.argp_deg) + 2 * np.pi * dt / (el.p_argp_yr * _YEAR_S)
    O = np.radians(el.node_deg) - 2 * np.pi * dt / (el.p_node_yr * _YEAR_S)
    ci, si = math.cos(math.radians(el.i_deg)), math.sin(math.radians(el.i_deg))
    cO, sO, cw, sw = np.cos(O), np.sin(O), np.cos(w), np.sin(w)
    # Perifocal -> Laplace-plane frame: R3(-node) R1(-i) R3(-w), first two columns; then to ICRF.
    P = np.stack([cO * cw - sO * sw * ci, sO * cw + cO * sw * ci, sw * si], axis=-1) @ _FRAMES[name.lower()].T
    Q = np.stack([-cO * sw - sO * cw * ci, -sO * sw + cO * cw * ci, cw * si], axis=-1) @ _FRAMES[name.lower()].T
    pos = xp[..., None] * P + yp[..., None] * Q
    vel = vxp[..., None] * P + vyp[..., None] * Q
    return pos, vel


def _moon_state_at(el: MoonElements, frame: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`moon_state` at one epoch, on Python floats: an optical measurement asks for one
    epoch, and numpy on 0-d arrays cost ten times the arithmetic. Every operation is the array
    form's, in its order (``%`` is ``np.mod``, ``math.radians`` is ``np.radians``, ``math.sin``
    and ``math.cos`` are numpy's to the bit here; the two rotations stay numpy's matmul), so
    the result is the array form's to the bit (``tests/test_astro_moons.py``)."""
    if not math.isfinite(t):
        raise MoonError("non-finite time")
    dt = t - _EPOCH_S
    n = el.mean_motion
    e = el.e
    M = math.radians((el.mean_anomaly_deg + el.n_deg_day * (dt / SECONDS_PER_DAY)) % 360.0) % (2 * math.pi)
    # solve_kepler, one value
    E = M + e * math.sin(M)
    for _ in range(30):
        dE = (E - e * math.sin(E) - M) / (1.0 - e * math.cos(E))
        E = E - dE
        if abs(dE) < 1e-14:
            break
    cE, sE = math.cos(E), math.sin(E)
    b = el.a_km * math.sqrt(1.0 - e**2)
    xp = el.a_km * (cE - e)
    yp = b * sE
    Edot = n / (1.0 - e * cE)
    vxp = -el.a_km * sE * Edot
    vyp = b * cE * Edot
    w = math.radians(el.argp_deg) + 2 * math.pi * dt / (el.p_argp_yr * _YEAR_S)
    O = math.radians(el.node_deg) - 2 * math.pi * dt / (el.p_node_yr * _YEAR_S)
    ci, si = math.cos(math.radians(el.i_deg)), math.sin(math.radians(el.i_deg))
    cO, sO, cw, sw = math.cos(O), math.sin(O), math.cos(w), math.sin(w)
    P = np.array([cO * cw - sO * sw * ci, sO * cw + cO * sw * ci, sw * si]) @ frame.T
    Q = np.array([-cO * sw - sO * cw * ci, -sO * sw + cO * cw * ci, cw * si]) @ frame.T
    return xp * P + yp * Q, vxp * P + vyp * Q

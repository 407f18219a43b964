"""Truth Phobos and Deimos: JPL's published mean elements, precessing in their Laplace planes.

JPL Solar System Dynamics, "Planetary Satellite Mean Elements" (ssd.jpl.nasa.gov/sats/elem),
Mars satellites from the MAR080 ephemeris (Jacobson 2010), epoch 1950 Jan 1.00 TT, referred to
each moon's local Laplace plane: a, e, argument of periapsis w, mean anomaly M, inclination i,
node (from the node of the Laplace plane on the ICRF equator), mean motion n, periapsis and
node precession periods P_w, P_node, and the Laplace-plane pole (RA, Dec). The position at t is
the ellipse with M = M0 + n dt, w = w0 + 360 deg dt / P_w (apsides advance) and
node = node0 - 360 deg dt / P_node (the node regresses), a precessing ellipse fitted by JPL to
the integrated orbit — the page warns the fit is not an ephemeris; here it is the simulated
world. Velocity: the central difference of the position over +-0.5 s (< 1e-8 km/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import erfa
import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY

_EPOCH_TT_S = (2433282.5 - 2451545.0) * SECONDS_PER_DAY  # 1950 Jan 1.00 TT
_EPOCH_S = _EPOCH_TT_S + float(erfa.dtdb(2433282.5, 0.0, 0.0, 0.0, 0.0, 0.0))  # as TDB
_YEAR_DAYS = 365.25


class TruthMoonError(ValueError):
    """Unknown moon or non-finite time."""


@dataclass(frozen=True)
class MeanElements:
    """One row of JPL's mean-element table (km, deg, deg/day, years)."""

    a_km: float
    e: float
    argp_deg: float
    mean_anomaly_deg: float
    i_deg: float
    node_deg: float
    n_deg_day: float
    p_argp_yr: float
    p_node_yr: float
    pole_ra_deg: float
    pole_dec_deg: float


MOONS: dict[str, MeanElements] = {
    "phobos": MeanElements(9376.0, 0.0151, 150.057, 91.059, 1.075, 207.784, 1128.8447569, 1.1316, 2.2617,
                           317.671, 52.893),
    "deimos": MeanElements(23458.0, 0.0002, 260.729, 325.329, 1.788, 24.525, 285.1618790, 27.3703, 54.5367,
                           316.657, 53.529),
}


def _laplace_frame(el: MeanElements) -> np.ndarray:
    ra, dec = math.radians(el.pole_ra_deg), math.radians(el.pole_dec_deg)
    z = np.array([math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)])
    x = np.array([-math.sin(ra), math.cos(ra), 0.0])
    return np.column_stack([x, np.cross(z, x), z])


def _position(el: MeanElements, t: np.ndarray) -> np.ndarray:
    days = (t - _EPOCH_S) / SECONDS_PER_DAY
    M = np.radians(np.mod(el.mean_anomaly_deg + el.n_deg_day * days, 360.0))
    w = np.radians(el.argp_deg + 360.0 * days / (el.p_argp_yr * _YEAR_DAYS))
    node = np.radians(el.node_deg - 360.0 * days / (el.p_node_yr * _YEAR_DAYS))
    E = M + el.e * np.sin(M)
    for _ in range(8):  # Newton; e < 0.02 converges to 1e-16 in 3
        E = E - (E - el.e * np.sin(E) - M) / (1.0 - el.e * np.cos(E))
    xp = el.a_km * (np.cos(E) - el.e)
    yp = el.a_km * math.sqrt(1.0 - el.e**2) * np.sin(E)
    ci, si = math.cos(math.radians(el.i_deg)), math.sin(math.radians(el.i_deg))
    cO, sO, cw, sw = np.cos(node), np.sin(node), np.cos(w), np.sin(w)
    P = np.stack([cO * cw - sO * sw * ci, sO * cw + cO * sw * ci, sw * si], axis=-1)
    Q = np.stack([-cO * sw - sO * cw * ci, -sO * sw + cO * cw * ci, cw * si], axis=-1)
    return (xp[..., None] * P + yp[..., None] * Q) @ _laplace_frame(el).T


def moon_state(name: str, t_tdb) -> tuple[np.ndarray, np.ndarray]:
    """Mars-centred ICRF position [km] and velocity [km/s]; scalar t -> (3,), (N,) -> (N, 3)."""
    try:
        el = MOONS[name.lower()]
    except (KeyError, AttributeError):
        raise TruthMoonError(f"unknown moon {name!r}; known: {', '.join(MOONS)}") from None
    t = np.asarray(t_tdb, dtype=float)
    if not np.all(np.isfinite(t)):
        raise TruthMoonError("non-finite time")
    h = 0.5
    pos = _position(el, t)
    vel = (_position(el, t + h) - _position(el, t - h)) / (2 * h)
    return pos, vel

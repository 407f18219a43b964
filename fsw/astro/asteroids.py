"""The onboard catalogue of asteroid beacons for optical navigation.

Lubey & Ely 2022 (Table 1) give their filters "ephemerides for ... other optical targets (i.e.,
asteroids)". Onboard, each beacon is a two-body heliocentric orbit from the Minor Planet
Center's osculating elements (MPCORB.DAT, epoch 2011 Aug. 27.0 TT = JD 2455800.5; ecliptic and
equinox J2000.0): semi-major axis a [au], eccentricity e, inclination i, node W, argument of
perihelion w and mean anomaly M at the epoch [deg]. The mean motion is sqrt(GM_sun / a³) from
the onboard GM of the Sun.

Position from the Gauss vectors P, Q (unit vectors to perihelion and 90° ahead of it in the
orbit plane): r = a (cos E − e) P + a sqrt(1 − e²) sin E Q, with Kepler's equation
M = E − e sin E solved by Newton's method; velocity is its exact time derivative. The ecliptic
vectors are turned into ICRF by the J2000 obliquity (IAU 1976, 84381.448").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import AU_KM, GM_SUN, SECONDS_PER_DAY

_EPS = math.radians(84381.448 / 3600.0)
#: Epoch of the catalogue, TDB seconds past J2000.
EPOCH_S = (2455800.5 - 2451545.0) * SECONDS_PER_DAY


@dataclass(frozen=True)
class Beacon:
    """One catalogue asteroid: Gauss vectors (ICRF), a [km], e, mean motion [rad/s], M0 [rad]."""

    name: str
    P: np.ndarray
    Q: np.ndarray
    a_km: float
    e: float
    n_rad_s: float
    M0: float


def _beacon(name: str, a_au: float, e: float, i: float, node: float, w: float, M: float) -> Beacon:
    i, node, w = math.radians(i), math.radians(node), math.radians(w)
    cW, sW, ci, si, cw, sw = math.cos(node), math.sin(node), math.cos(i), math.sin(i), math.cos(w), math.sin(w)
    P_ecl = np.array([cW * cw - sW * sw * ci, sW * cw + cW * sw * ci, sw * si])
    Q_ecl = np.array([-cW * sw - sW * cw * ci, -sW * sw + cW * cw * ci, cw * si])
    ce, se = math.cos(_EPS), math.sin(_EPS)
    to_icrf = np.array([[1.0, 0.0, 0.0], [0.0, ce, -se], [0.0, se, ce]])
    a_km = a_au * AU_KM
    return Beacon(name, to_icrf @ P_ecl, to_icrf @ Q_ecl, a_km, e, math.sqrt(GM_SUN / a_km**3), math.radians(M))


#: name: (a [au], e, i, W, w, M [deg]) from MPCORB.DAT at epoch K118R.
_ELEMENTS: dict[str, tuple[float, float, float, float, float, float]] = {
    "ceres": (2.7665466, 0.0785634, 10.58595, 80.37910, 72.44742, 199.31747),
    "pallas": (2.7711488, 0.2312416, 34.84160, 173.12644, 310.06331, 181.70142),
    "juno": (2.6711744, 0.2551627, 12.98086, 169.91025, 248.18733, 122.32357),
    "vesta": (2.3612165, 0.0883124, 7.13461, 103.90428, 149.88186, 56.40276),
    "hebe": (2.4247124, 0.2022525, 14.75022, 138.72650, 239.28896, 76.23230),
    "iris": (2.3862672, 0.2305428, 5.52306, 259.65080, 145.26277, 111.53561),
    "flora": (2.2010492, 0.1564761, 5.88786, 110.93525, 285.18420, 70.05922),
    "metis": (2.3855446, 0.1227453, 5.57547, 68.94919, 6.24383, 248.44234),
    "hygiea": (3.1389913, 0.1164623, 3.84094, 283.41502, 313.01188, 15.29657),
    "eunomia": (2.6440716, 0.1886022, 11.73525, 293.21965, 97.67316, 2.13972),
}

BEACONS: dict[str, Beacon] = {name: _beacon(name, *el) for name, el in _ELEMENTS.items()}
#: Beacon names, in catalogue order.
NAMES: tuple[str, ...] = tuple(BEACONS)


def beacon_state(name: str, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Heliocentric ICRF position [km] and velocity [km/s] of beacon ``name`` at TDB t."""
    b = BEACONS[name]
    M = math.remainder(b.M0 + b.n_rad_s * (t - EPOCH_S), 2.0 * math.pi)
    E = M
    for _ in range(20):
        step = (E - b.e * math.sin(E) - M) / (1.0 - b.e * math.cos(E))
        E -= step
        if abs(step) < 1e-14:
            break
    cE, sE = math.cos(E), math.sin(E)
    root = math.sqrt(1.0 - b.e * b.e)
    Edot = b.n_rad_s / (1.0 - b.e * cE)
    r = b.a_km * ((cE - b.e) * b.P + root * sE * b.Q)
    v = b.a_km * Edot * (-sE * b.P + root * cE * b.Q)
    return r, v

"""Truth ephemerides of the asteroid beacons the navigation camera images.

Ten bright main-belt asteroids, with the Minor Planet Center's osculating elements of MPCORB.DAT
at epoch 2011 Aug. 27.0 TT (JD 2455800.5, packed K118R): heliocentric, ecliptic and equinox
J2000.0, mean anomaly M, argument of perihelion w, node W, inclination i, eccentricity e, mean
daily motion n, semi-major axis a, absolute magnitude H and slope G (the H, G system of Bowell
et al. 1989).

The truth propagates them as unperturbed two-body orbits about the Sun with the MPC's own mean
motion n (the onboard catalogue, :mod:`fsw.astro.asteroids`, takes n from a and its GM of the
Sun instead: the two differ by ~1e-7 of n, up to a few hundred km after the seven years to
2018, a small ephemeris error the filter does not know of). Planetary perturbations are left out
of both: over seven years Jupiter moves a main-belt asteroid by 1e5-1e6 km from its two-body
path, so these are the real asteroids' orbits, not their real 2018 positions.

Apparent magnitude (Bowell et al. 1989):
V = H + 5 log10(r Δ) − 2.5 log10[(1 − G) Φ1(α) + G Φ2(α)], Φk = exp(−Ak tan(α/2)^Bk),
A1 = 3.33, B1 = 0.63, A2 = 1.87, B2 = 1.22, with r and Δ the distances to the Sun and the
observer [au] and α the phase angle (Sun–asteroid–observer).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_AU_KM = 149597870.7
_DAY_S = 86400.0
#: Obliquity of the J2000 ecliptic (IAU 1976, the MPC's and JPL's "IAU76/J2000" ecliptic).
_OBLIQUITY_RAD = np.radians(84381.448 / 3600.0)
#: The elements' epoch, TDB seconds past J2000 (TT − TDB < 2 ms is left out).
EPOCH_S = (2455800.5 - 2451545.0) * _DAY_S


@dataclass(frozen=True)
class Elements:
    """MPCORB osculating elements (angles in degrees, a in au, n in deg/day)."""

    number: int
    name: str
    H: float
    G: float
    M: float
    w: float
    node: float
    i: float
    e: float
    n: float
    a: float


#: MPCORB.DAT, epoch K118R (2011 Aug. 27.0 TT).
CATALOGUE: tuple[Elements, ...] = (
    Elements(1, "ceres", 3.34, 0.12, 199.31747, 72.44742, 80.37910, 10.58595, 0.0785634, 0.21418897, 2.7665466),
    Elements(2, "pallas", 4.13, 0.11, 181.70142, 310.06331, 173.12644, 34.84160, 0.2312416, 0.21365561, 2.7711488),
    Elements(3, "juno", 5.33, 0.32, 122.32357, 248.18733, 169.91025, 12.98086, 0.2551627, 0.22576192, 2.6711744),
    Elements(4, "vesta", 3.20, 0.32, 56.40276, 149.88186, 103.90428, 7.13461, 0.0883124, 0.27164416, 2.3612165),
    Elements(6, "hebe", 5.71, 0.24, 76.23230, 239.28896, 138.72650, 14.75022, 0.2022525, 0.26104401, 2.4247124),
    Elements(7, "iris", 5.51, 0.15, 111.53561, 145.26277, 259.65080, 5.52306, 0.2305428, 0.26737788, 2.3862672),
    Elements(8, "flora", 6.49, 0.28, 70.05922, 285.18420, 110.93525, 5.88786, 0.1564761, 0.30182794, 2.2010492),
    Elements(9, "metis", 6.28, 0.17, 248.44234, 6.24383, 68.94919, 5.57547, 0.1227453, 0.26749937, 2.3855446),
    Elements(10, "hygiea", 5.43, 0.15, 15.29657, 313.01188, 283.41502, 3.84094, 0.1164623, 0.17722252, 3.1389913),
    Elements(15, "eunomia", 5.28, 0.23, 2.13972, 97.67316, 293.21965, 11.73525, 0.1886022, 0.22924203, 2.6440716),
)

BY_NAME: dict[str, Elements] = {el.name: el for el in CATALOGUE}
NAMES: tuple[str, ...] = tuple(BY_NAME)


def _rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _perifocal_to_icrf(el: Elements) -> np.ndarray:
    """Perifocal → ecliptic (R3(W) R1(i) R3(w)) → ICRF (R1(ε))."""
    return _rot_x(_OBLIQUITY_RAD) @ _rot_z(np.radians(el.node)) @ _rot_x(np.radians(el.i)) @ _rot_z(np.radians(el.w))


def heliocentric_state(name: str, t) -> tuple[np.ndarray, np.ndarray]:
    """Heliocentric ICRF position [km] and velocity [km/s] (N, 3) of asteroid ``name`` at TDB t (N,)."""
    el = BY_NAME[name]
    t = np.atleast_1d(np.asarray(t, dtype=float))
    n_rad_s = np.radians(el.n) / _DAY_S
    M = np.radians(el.M) + n_rad_s * (t - EPOCH_S)
    M = np.mod(M + np.pi, 2.0 * np.pi) - np.pi
    e = el.e
    E = M + e * np.sin(M)
    for _ in range(30):
        dE = (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
        E -= dE
        if np.max(np.abs(dE)) < 1e-15:
            break
    a = el.a * _AU_KM
    b = a * np.sqrt(1.0 - e * e)
    cE, sE = np.cos(E), np.sin(E)
    Edot = n_rad_s / (1.0 - e * cE)
    pos = np.column_stack((a * (cE - e), b * sE, np.zeros_like(E)))
    vel = np.column_stack((-a * sE * Edot, b * cE * Edot, np.zeros_like(E)))
    R = _perifocal_to_icrf(el)
    return pos @ R.T, vel @ R.T


def apparent_magnitude(name: str, sun_dist_km: np.ndarray, obs_dist_km: np.ndarray, phase_rad: np.ndarray) -> np.ndarray:
    """V magnitude in the H, G system (Bowell et al. 1989; module docstring)."""
    el = BY_NAME[name]
    th = np.tan(0.5 * np.asarray(phase_rad, dtype=float))
    phi1 = np.exp(-3.33 * th**0.63)
    phi2 = np.exp(-1.87 * th**1.22)
    r = np.asarray(sun_dist_km, dtype=float) / _AU_KM
    d = np.asarray(obs_dist_km, dtype=float) / _AU_KM
    with np.errstate(divide="ignore"):  # fully back-lit (alpha = 180 deg): no light, V = +inf
        return el.H + 5.0 * np.log10(r * d) - 2.5 * np.log10((1.0 - el.G) * phi1 + el.G * phi2)

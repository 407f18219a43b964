"""Lambert's problem, zero revolutions, by the universal-variable method; two-body conic propagation.

Universal-variable formulation (Bate, Mueller & White §5.3; Curtis, Algorithm 5.2), z = alpha chi^2
with Stumpff functions C(z), S(z):

    A    = s sin(dnu) sqrt(r1 r2 / (1 - cos dnu)),     s = +1 (the transfer turns with the angular
                                                      momentum chosen, prograde by default)
    y(z) = r1 + r2 + A (z S(z) - 1) / sqrt(C(z))
    F(z) = (y / C)^(3/2) S + A sqrt(y) - sqrt(mu) dt = 0
    f = 1 - y/r1,  g = A sqrt(y/mu),  gdot = 1 - y/r2
    v1 = (r2 - f r1) / g,  v2 = (gdot r2 - r1) / g

For zero revolutions F increases monotonically with z on the interval where y > 0 and z < 4 pi^2,
so the root is bracketed and found with Brent's method. A Type-I transfer is the short way
(0 < dnu < 180 deg).

The conic propagation (``kepler``) is the universal-anomaly Kepler solution with Lagrange
coefficients (Curtis, Algorithms 3.3/3.4).
"""

from __future__ import annotations

import math

import numpy as np


class LambertError(ValueError):
    """Bad Lambert geometry (coincident or opposite positions, non-positive time of flight)."""


def stumpff(z: float) -> tuple[float, float]:
    """(C(z), S(z)); series near z = 0 where the closed forms cancel."""
    if abs(z) < 1e-3:
        # C = 1/2 - z/24 + z^2/720 - ..., S = 1/6 - z/120 + z^2/5040 - ...
        return (0.5 - z / 24.0 + z * z / 720.0 - z**3 / 40320.0,
                1.0 / 6.0 - z / 120.0 + z * z / 5040.0 - z**3 / 362880.0)
    if z > 0.0:
        s = math.sqrt(z)
        return (1.0 - math.cos(s)) / z, (s - math.sin(s)) / (s * z)
    s = math.sqrt(-z)
    return (math.cosh(s) - 1.0) / -z, (math.sinh(s) - s) / (s * -z)


def lambert(r1, r2, tof_s: float, mu: float, prograde: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Velocities (v1, v2) [km/s] of the zero-revolution conic from r1 to r2 [km] in ``tof_s``.

    ``prograde``: the transfer's angular momentum has a positive z component (ecliptic/equatorial
    north), which picks the short or long way accordingly.
    """
    r1 = np.asarray(r1, dtype=float)
    r2 = np.asarray(r2, dtype=float)
    if r1.shape != (3,) or r2.shape != (3,) or not (np.all(np.isfinite(r1)) and np.all(np.isfinite(r2))):
        raise LambertError("positions must be finite 3-vectors")
    if not (math.isfinite(tof_s) and tof_s > 0.0 and mu > 0.0):
        raise LambertError(f"time of flight and mu must be positive, got {tof_s}, {mu}")
    n1, n2 = float(np.linalg.norm(r1)), float(np.linalg.norm(r2))
    cos_dnu = float(np.clip(np.dot(r1, r2) / (n1 * n2), -1.0, 1.0))
    cz = float(np.cross(r1, r2)[2])
    dnu = math.acos(cos_dnu)
    if (prograde and cz < 0.0) or (not prograde and cz >= 0.0):
        dnu = 2.0 * math.pi - dnu
    if abs(math.sin(dnu)) < 1e-10 or 1.0 - cos_dnu < 1e-14:
        raise LambertError("r1 and r2 are (anti-)parallel: the transfer plane is undefined")
    A = math.sin(dnu) * math.sqrt(n1 * n2 / (1.0 - cos_dnu))
    sqrt_mu = math.sqrt(mu)
    # imported here: the scenario configuration imports this module in every process (0.1 s)
    from scipy.optimize import brentq

    def y(z: float) -> float:
        C, S = stumpff(z)
        return n1 + n2 + A * (z * S - 1.0) / math.sqrt(C)

    def F(z: float) -> float:
        C, S = stumpff(z)
        yz = y(z)
        return (yz / C) ** 1.5 * S + A * math.sqrt(yz) - sqrt_mu * tof_s

    z_hi = 4.0 * math.pi**2 * (1.0 - 1e-6)
    if F(z_hi) < 0.0:
        raise LambertError("time of flight too long for a zero-revolution transfer")
    z_lo = -1.0
    while True:
        if y(z_lo) <= 0.0:
            # F < 0 where y reaches 0 (only the -sqrt(mu) dt term is left): the root lies above
            z0 = brentq(y, z_lo, z_hi, xtol=1e-15)
            z_lo = z0 + max(1e-12, 1e-12 * abs(z0))
            while y(z_lo) <= 0.0:
                z_lo += max(1e-12, 1e-9 * abs(z_lo))
            break
        if F(z_lo) <= 0.0:
            break
        z_lo *= 2.0
        if z_lo < -1e8:
            raise LambertError("no zero-revolution solution bracketed")
    z = brentq(F, z_lo, z_hi, xtol=1e-14, rtol=1e-15, maxiter=200)
    yz = y(z)
    f = 1.0 - yz / n1
    g = A * math.sqrt(yz / mu)
    gdot = 1.0 - yz / n2
    return (r2 - f * r1) / g, (gdot * r2 - r1) / g


def kepler(r0, v0, dt_s: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """Two-body state (r, v) after dt_s from (r0, v0) along the conic (universal anomaly)."""
    r0 = np.asarray(r0, dtype=float)
    v0 = np.asarray(v0, dtype=float)
    n0 = float(np.linalg.norm(r0))
    vr0 = float(np.dot(r0, v0)) / n0
    alpha = 2.0 / n0 - float(np.dot(v0, v0)) / mu
    sqrt_mu = math.sqrt(mu)
    chi = sqrt_mu * abs(alpha) * dt_s if alpha > 0 else sqrt_mu * dt_s / n0
    for _ in range(100):
        z = alpha * chi * chi
        C, S = stumpff(z)
        Fx = n0 * vr0 / sqrt_mu * chi * chi * C + (1.0 - alpha * n0) * chi**3 * S + n0 * chi - sqrt_mu * dt_s
        dF = n0 * vr0 / sqrt_mu * chi * (1.0 - z * S) + (1.0 - alpha * n0) * chi * chi * C + n0
        step = Fx / dF
        chi -= step
        if abs(step) < 1e-13 * max(1.0, abs(chi)):
            break
    z = alpha * chi * chi
    C, S = stumpff(z)
    f = 1.0 - chi * chi / n0 * C
    g = dt_s - chi**3 / sqrt_mu * S
    r = f * r0 + g * v0
    n = float(np.linalg.norm(r))
    fdot = sqrt_mu / (n * n0) * (alpha * chi**3 * S - chi)
    gdot = 1.0 - chi * chi / n * C
    return r, fdot * r0 + gdot * v0

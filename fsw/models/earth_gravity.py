"""Onboard Earth-centred dynamics: point mass plus J2 (the FSW's own model of an Earth orbiter,
deliberately simpler than the truth's zonals and drag), with the gravity gradient for the
variational equations and a fixed-step RK4 propagator of the state and its transition matrix.

a = −μ r/|r|³ + a_J2,  a_J2 = −(3/2) J2 μ R²/|r|⁵ [x(1 − 5z²/r²), y(1 − 5z²/r²), z(3 − 5z²/r²)]
(Vallado, Fundamentals of Astrodynamics, eq. 8-30); J2 = 1.08262668e-3 (EGM2008 C̄20 unnormalised).
"""

from __future__ import annotations

import numpy as np

from fsw.astro.constants import GM_EARTH, R_EARTH_EQ_KM

J2_EARTH: float = 1.08262668e-3


def acceleration(r: np.ndarray, j2: float = J2_EARTH) -> np.ndarray:
    """(…, 3) acceleration [km/s²] at Earth-centred positions r (…, 3) [km]."""
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    r2 = x * x + y * y + z * z
    rn = np.sqrt(r2)
    k = GM_EARTH / (r2 * rn)
    f = 1.5 * j2 * GM_EARTH * R_EARTH_EQ_KM ** 2 / (r2 * r2 * rn)
    s = 5.0 * z * z / r2
    return np.stack([-k * x - f * x * (1.0 - s), -k * y - f * y * (1.0 - s), -k * z - f * z * (3.0 - s)], axis=-1)


def gradient(r: np.ndarray, j2: float = J2_EARTH, h: float = 1e-3) -> np.ndarray:
    """∂a/∂r (…, 3, 3): the point-mass term exactly, the J2 term (a 10⁻³ correction) by a
    central difference over ±h km (relative error ~ (h/r)², far below the filter's needs)."""
    rn = np.linalg.norm(r, axis=-1)[..., None, None]
    rr = r[..., :, None] * r[..., None, :]
    G = GM_EARTH * (3.0 * rr / rn ** 5 - np.eye(3) / rn ** 3)
    out = np.empty(r.shape[:-1] + (3, 3))
    for j in range(3):
        dr = np.zeros(3)
        dr[j] = h
        out[..., :, j] = (acceleration(r + dr, j2) - acceleration(r - dr, j2) - acceleration(r + dr, 0.0)
                          + acceleration(r - dr, 0.0)) / (2 * h)
    return G + out


def _deriv(z: np.ndarray, phi: np.ndarray, j2: float) -> tuple[np.ndarray, np.ndarray]:
    a = acceleration(z[..., 0:3], j2)
    A = np.zeros(z.shape[:-1] + (6, 6))
    A[..., 0:3, 3:6] = np.eye(3)
    A[..., 3:6, 0:3] = gradient(z[..., 0:3], j2)
    return np.concatenate([z[..., 3:6], a], axis=-1), A @ phi


def propagate(z: np.ndarray, dt: float, step_s: float = 1.0, j2: float = J2_EARTH) -> tuple[np.ndarray, np.ndarray]:
    """States z (N, 6) carried over dt by RK4 steps of at most step_s; returns (z(t + dt),
    Φ (N, 6, 6)), Φ integrated with the same stages (variational equations)."""
    n = max(1, int(np.ceil(abs(dt) / step_s - 1e-9)))
    h = dt / n
    phi = np.broadcast_to(np.eye(6), z.shape[:-1] + (6, 6)).copy()
    for _ in range(n):
        k1, p1 = _deriv(z, phi, j2)
        k2, p2 = _deriv(z + 0.5 * h * k1, phi + 0.5 * h * p1, j2)
        k3, p3 = _deriv(z + 0.5 * h * k2, phi + 0.5 * h * p2, j2)
        k4, p4 = _deriv(z + h * k3, phi + h * p3, j2)
        z = z + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        phi = phi + h / 6.0 * (p1 + 2 * p2 + 2 * p3 + p4)
    return z, phi

"""Onboard model of ground-station tracking of an Earth orbiter: range, range rate, azimuth and
elevation (the measurements of Garhwal, Halder & Sinha) and their exact partials.

With d = r − r_s and w = v − v_s (spacecraft minus station, GCRS) and the station's east, north,
up unit vectors e, n, u:

    ρ = |d|,  ρ̇ = d·w / ρ,  Az = atan2(d·e, d·n),  El = asin(d·u / ρ)

    ∂ρ/∂r = d/ρ                       ∂ρ̇/∂r = (w − ρ̇ d/ρ)/ρ,   ∂ρ̇/∂v = d/ρ
    ∂Az/∂r = ((d·n) e − (d·e) n) / ((d·e)² + (d·n)²)
    ∂El/∂r = (u − sin El · d/ρ) / (ρ cos El)

Geometry at the time tag (no light time, stated in the ICD declarations).
"""

from __future__ import annotations

import math

import numpy as np

#: Component order of :func:`predict`.
COMPONENTS: tuple[str, ...] = ("station-range", "station-range-rate", "azimuth", "elevation")


def predict(r: np.ndarray, v: np.ndarray, r_s: np.ndarray, v_s: np.ndarray,
            enu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """h (N, 4) = [ρ, ρ̇, Az, El] and H (N, 4, 6) = ∂h/∂[r, v] for spacecraft states (N, 3)
    seen from stations at r_s, v_s (N, 3) with east/north/up rows enu (N, 3, 3)."""
    r = np.atleast_2d(r)
    d = r - r_s
    w = np.atleast_2d(v) - v_s
    e, n, u = enu[:, 0], enu[:, 1], enu[:, 2]
    rho = np.linalg.norm(d, axis=1)
    rdot = np.einsum("ij,ij->i", d, w) / rho
    de = np.einsum("ij,ij->i", d, e)
    dn = np.einsum("ij,ij->i", d, n)
    du = np.einsum("ij,ij->i", d, u)
    az = np.mod(np.arctan2(de, dn), 2.0 * math.pi)
    sin_el = du / rho
    el = np.arcsin(np.clip(sin_el, -1.0, 1.0))
    N = r.shape[0]
    H = np.zeros((N, 4, 6))
    los = d / rho[:, None]
    H[:, 0, 0:3] = los
    H[:, 1, 0:3] = (w - rdot[:, None] * los) / rho[:, None]
    H[:, 1, 3:6] = los
    H[:, 2, 0:3] = (dn[:, None] * e - de[:, None] * n) / (de * de + dn * dn)[:, None]
    H[:, 3, 0:3] = (u - sin_el[:, None] * los) / (rho * np.cos(el))[:, None]
    return np.column_stack([rho, rdot, az, el]), H


def wrap_residual(residual: np.ndarray, components: tuple[str, ...]) -> np.ndarray:
    """Residuals with the azimuth components wrapped into (−π, π]."""
    out = np.array(residual, dtype=float, copy=True)
    for k, name in enumerate(components):
        if name == "azimuth":
            out[..., k] = (out[..., k] + math.pi) % (2.0 * math.pi) - math.pi
    return out

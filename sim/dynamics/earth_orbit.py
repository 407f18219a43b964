"""Truth dynamics of an Earth orbiter just after injection: zonal gravity J2–J4 and drag in an
exponential atmosphere that rotates with the Earth.

Zonals (Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., eqs. 8-30 to 8-32;
values EGM2008 unnormalised): J2 = 1.08262668e-3, J3 = −2.53265649e-6, J4 = −1.61962159e-6, with
the WGS84 equatorial radius and GM of :mod:`fsw.astro.constants` (nature's constants only).
The Earth's figure axis is taken as GCRS z (the ~0.3° precession of the pole since J2000 tilts
the zonal field by that much: a 10⁻³-relative effect on J2's acceleration, well below what a
few-minute tracking arc resolves; stated, not modelled).

Drag: a = −½ ρ(h) (C_D A / m) |v_r| v_r with v_r = v − ω⊕ × r, ρ(h) = ρ₀ exp(−(h − h₀)/H) above a
spherical Earth of the equatorial radius. Default ρ₀ = 6.967e-13 kg/m³ at h₀ = 500 km with
H = 63.822 km (Vallado, Table 8-4, the 500–600 km band), C_D A/m = 2.2 × 4 m² / 710 kg
(a Cartosat-2-class spacecraft; stated, not a published figure).

Propagation: scipy's DOP853 with rtol 1e-12, atol 1e-9 km (truth accuracy far below the
tracking noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import GM_EARTH, OMEGA_EARTH_RAD_S, R_EARTH_EQ_KM
from fsw.interface.typed import spec

J2, J3, J4 = 1.08262668e-3, -2.53265649e-6, -1.61962159e-6


@dataclass(frozen=True, slots=True)
class EarthForceConfig:
    """Truth forces on an Earth orbiter."""

    zonals: int = spec(4, doc="highest zonal harmonic of the truth gravity (0: point mass, 2: J2, 3, 4)", ge=0, le=4)
    drag: bool = spec(True, doc="atmospheric drag (exponential atmosphere)")
    rho0_kg_m3: float = spec(6.967e-13, doc="density at the reference height (Vallado Table 8-4, 500 km)", unit="kg/m^3", gt=0.0)
    h0_km: float = spec(500.0, doc="reference height of the exponential atmosphere", unit="km", ge=0.0)
    scale_height_km: float = spec(63.822, doc="density scale height (Vallado Table 8-4, 500-600 km)", unit="km", gt=0.0)
    cd_area_over_mass_m2_kg: float = spec(
        2.2 * 4.0 / 710.0, doc="ballistic coefficient C_D A / m (2.2 x 4 m^2 / 710 kg)", unit="m^2/kg", gt=0.0)


def zonal_acceleration(r: np.ndarray, zonals: int) -> np.ndarray:
    """Point mass plus J2..J_zonals, (…, 3) km/s² at r (…, 3) km (Vallado eqs. 8-30 to 8-32)."""
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    r2 = x * x + y * y + z * z
    rn = np.sqrt(r2)
    mu = GM_EARTH
    R = R_EARTH_EQ_KM
    u = z / rn
    a = -mu / (r2 * rn) * np.stack([x, y, z], axis=-1)
    if zonals >= 2:
        f = -1.5 * J2 * mu * R ** 2 / rn ** 5
        a = a + np.stack([f * x * (1 - 5 * u * u), f * y * (1 - 5 * u * u), f * z * (3 - 5 * u * u)], axis=-1)
    if zonals >= 3:
        f = -2.5 * J3 * mu * R ** 3 / rn ** 7
        a = a + np.stack([f * x * (3 * z - 7 * z * u * u), f * y * (3 * z - 7 * z * u * u),
                          f * (6 * z * z - 7 * z * z * u * u - 0.6 * r2)], axis=-1)
    if zonals >= 4:
        f = 15.0 / 8.0 * J4 * mu * R ** 4 / rn ** 7
        g = 1 - 14 * u * u + 21 * u ** 4
        a = a + np.stack([f * x * g, f * y * g, f * z * (5 - 70.0 / 3.0 * u * u + 21 * u ** 4)], axis=-1)
    return a


def drag_acceleration(r: np.ndarray, v: np.ndarray, cfg: EarthForceConfig) -> np.ndarray:
    """−½ ρ C_D A/m |v_r| v_r in km/s² (ρ in kg/m³, A/m in m²/kg: the km/m factor 1e3)."""
    w = np.array([0.0, 0.0, OMEGA_EARTH_RAD_S])
    vr = v - np.cross(w, r)
    h = np.linalg.norm(r, axis=-1) - R_EARTH_EQ_KM
    rho = cfg.rho0_kg_m3 * np.exp(-(h - cfg.h0_km) / cfg.scale_height_km)
    speed = np.linalg.norm(vr, axis=-1)
    return (-0.5 * rho * cfg.cd_area_over_mass_m2_kg * 1e3 * speed)[..., None] * vr


def derivative(z: np.ndarray, cfg: EarthForceConfig) -> np.ndarray:
    a = zonal_acceleration(z[0:3], cfg.zonals)
    if cfg.drag:
        a = a + drag_acceleration(z[0:3], z[3:6], cfg)
    return np.concatenate([z[3:6], a])


def energy(z: np.ndarray, cfg: EarthForceConfig) -> np.ndarray:
    """Specific energy v²/2 − μ/r − U_J2 (conserved without drag when zonals ≤ 2), (…,)."""
    r = z[..., 0:3]
    rn = np.linalg.norm(r, axis=-1)
    u = r[..., 2] / rn
    e = 0.5 * np.sum(z[..., 3:6] ** 2, axis=-1) - GM_EARTH / rn
    if cfg.zonals >= 2:
        e = e + GM_EARTH / rn * J2 * (R_EARTH_EQ_KM / rn) ** 2 * 0.5 * (3 * u * u - 1)
    return e


def propagate(z0: np.ndarray, t_offsets: np.ndarray, cfg: EarthForceConfig) -> np.ndarray:
    """Truth states (K, 6) at t_offsets (K,) seconds after the state z0 (t_offsets ascending, ≥ 0)."""
    t = np.asarray(t_offsets, dtype=float)
    # imported here: the scenario configuration imports this module in every process (0.25 s)
    from scipy.integrate import solve_ivp

    sol = solve_ivp(lambda _t, z: derivative(z, cfg), (0.0, float(t[-1])), np.asarray(z0, dtype=float),
                    method="DOP853", t_eval=t, rtol=1e-12, atol=1e-9)
    if not sol.success:
        raise RuntimeError(f"truth propagation failed: {sol.message}")
    return np.asarray(sol.y.T)

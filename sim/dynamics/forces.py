"""Truth accelerations on the spacecraft, Mars-centred ICRF, km and s.

a = -GM_M r/|r|^3                                                   (Mars, central body)
  + sum_k GM_k [ (r_k - r)/|r_k - r|^3 - r_k/|r_k|^3 ]              (Sun, Earth-Moon, Jupiter;
                                                                     the second term is the
                                                                     indirect acceleration of Mars)
  + s(t) Cr (A/m) P_1AU (AU/d)^2 u                                  (cannonball SRP, u away
                                                                     from the Sun, no shadow:
                                                                     the approach is sunlit)
  + C_body(t) sum_i m_i(t) d_i                                      (ACS thrusting)
  + a_nga(t)                                                        (non-gravitational
                                                                     acceleration, ICRF axes)

Cruise body frame (InSight keeps its solar arrays on the Sun): z towards the Sun, x the
component of the Earth direction across the Sun line, y = z cross x. Earth is represented by
the Earth-Moon barycentre with the Earth+Moon GM; the Moon's offset changes the third-body
acceleration at Mars distances by < 1e-17 km/s^2.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from fsw.astro.constants import (
    AU_KM,
    GM_EARTH_MOON,
    GM_JUPITER_SYSTEM,
    GM_MARS,
    GM_SUN,
    P_SUN_1AU_N_M2,
)
from fsw.astro.ephemeris import EphemerisTable
from sim.dynamics.config import ForceModelConfig

# Rows of the ephemeris table used by the truth dynamics (order matters for the fast path).
TABLE_BODIES: tuple[str, ...] = ("sun", "emb", "jupiter")
_GM = (GM_SUN, GM_EARTH_MOON, GM_JUPITER_SYSTEM)


def srp_coefficient(forces: ForceModelConfig) -> float:
    """Cr (A/m) P_1AU AU^2 in km^3/s^2: SRP acceleration [km/s^2] = this * scale / d^2 [km]."""
    return forces.srp_cr * forces.srp_area_m2 / forces.srp_mass_kg * P_SUN_1AU_N_M2 * 1e-3 * AU_KM**2


def cruise_attitude(r_sc: np.ndarray, r_sun: np.ndarray, r_earth: np.ndarray) -> np.ndarray:
    """Columns: cruise body x, y, z axes in ICRF for (..., 3) positions (any common centre)."""
    z = r_sun - r_sc
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    e = r_earth - r_sc
    x = e - np.sum(e * z, axis=-1, keepdims=True) * z
    x = x / np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-1)


def make_rhs(
    forces: ForceModelConfig,
    table: EphemerisTable,
    srp_scale: float,
    acs_body: np.ndarray,
    nga: np.ndarray | None = None,
) -> Callable[[float, np.ndarray], np.ndarray]:
    """Equations of motion for one segment with constant SRP scale, body-frame ACS vector and
    inertial non-gravitational acceleration ``nga`` [km/s^2] (None: none)."""
    if table.bodies[: len(TABLE_BODIES)] != TABLE_BODIES or table.center != "mars":
        raise ValueError(f"the truth dynamics need a Mars-centred table of {TABLE_BODIES}")
    use = [forces.include_sun, forces.include_earth, forces.include_jupiter]
    gms = [gm if u else 0.0 for gm, u in zip(_GM, use)]
    k_srp = srp_coefficient(forces) * srp_scale if forces.srp_enabled else 0.0
    ax, ay, az = (float(v) for v in acs_body)
    acs_on = (ax, ay, az) != (0.0, 0.0, 0.0)
    nx, ny, nz = (0.0, 0.0, 0.0) if nga is None else (float(v) for v in nga)
    gm_mars = GM_MARS
    positions = table.positions
    sqrt = math.sqrt

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        # Python floats, not numpy scalars: the same IEEE operations at about a fifth of the cost
        # each (the solver calls this ~6,500 times a run)
        rx, ry, rz, vx, vy, vz = y.tolist()
        r2 = rx * rx + ry * ry + rz * rz
        c = -gm_mars / (r2 * sqrt(r2))
        a0, a1, a2 = c * rx, c * ry, c * rz
        P = positions(t).tolist()
        for k in range(3):
            gm = gms[k]
            if gm == 0.0:
                continue
            px, py, pz = P[k]
            dx, dy, dz = px - rx, py - ry, pz - rz
            d2 = dx * dx + dy * dy + dz * dz
            p2 = px * px + py * py + pz * pz
            cd = gm / (d2 * sqrt(d2))
            cp = gm / (p2 * sqrt(p2))
            a0 += cd * dx - cp * px
            a1 += cd * dy - cp * py
            a2 += cd * dz - cp * pz
        sx, sy, sz = rx - P[0][0], ry - P[0][1], rz - P[0][2]  # Sun -> spacecraft
        s2 = sx * sx + sy * sy + sz * sz
        s1 = sqrt(s2)
        if k_srp:
            cs = k_srp / (s2 * s1)
            a0 += cs * sx
            a1 += cs * sy
            a2 += cs * sz
        if acs_on:
            zx, zy, zz = -sx / s1, -sy / s1, -sz / s1
            ex, ey, ez = P[1][0] - rx, P[1][1] - ry, P[1][2] - rz
            ez_dot = ex * zx + ey * zy + ez * zz
            xx, xy, xz = ex - ez_dot * zx, ey - ez_dot * zy, ez - ez_dot * zz
            xn = sqrt(xx * xx + xy * xy + xz * xz)
            xx, xy, xz = xx / xn, xy / xn, xz / xn
            yx, yy, yz = zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx
            a0 += ax * xx + ay * yx + az * zx
            a1 += ax * xy + ay * yy + az * zy
            a2 += ax * xz + ay * yz + az * zz
        return np.array((vx, vy, vz, a0 + nx, a1 + ny, a2 + nz))

    return rhs


def acceleration_components(
    forces: ForceModelConfig, table: EphemerisTable, t: float, r: np.ndarray,
    srp_scale: float = 1.0, acs_body: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Each acceleration term at one epoch, vectorised form (diagnostics and tests)."""
    P = table.positions(t)
    r = np.asarray(r, dtype=float)
    out = {"mars": -GM_MARS * r / np.linalg.norm(r) ** 3}
    for name, k, use in (("sun", 0, forces.include_sun), ("earth", 1, forces.include_earth),
                         ("jupiter", 2, forces.include_jupiter)):
        d = P[k] - r
        out[name] = _GM[k] * (d / np.linalg.norm(d) ** 3 - P[k] / np.linalg.norm(P[k]) ** 3) if use else np.zeros(3)
    s = r - P[0]
    srp = srp_coefficient(forces) * srp_scale * s / np.linalg.norm(s) ** 3
    out["srp"] = srp if forces.srp_enabled else np.zeros(3)
    acs = np.zeros(3) if acs_body is None else cruise_attitude(r, P[0], P[1]) @ np.asarray(acs_body, dtype=float)
    out["acs"] = acs
    return out

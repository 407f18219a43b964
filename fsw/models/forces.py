"""Onboard force model: accelerations and their partials for a stack of N filters.

Mars-centred ICRF, km and s::

    a = −μ_M r/|r|³                                             Mars point mass
      + Σ_k μ_k [ (r_k − r)/|r_k − r|³ − r_k/|r_k|³ ]           Sun, Earth–Moon barycentre, Jupiter
                                                                (direct and indirect terms)
      + (1 + q_srp) K_srp (r − r_⊙)/|r − r_⊙|³                  cannonball SRP, K = Cr (A/m) P₁AU AU²
      + a_acs (1 + q_acs) C_cruise d_body                       ACS small force, cruise body frame
      + Σ_k c_k ((t − t_b)/T_b)^k                               batched polynomial acceleration

Cruise body frame (solar arrays on the Sun): z towards the Sun, x the component of the Earth
direction across the Sun line, y = z × x; d_body is the unit net thrust direction.

Partials: G = ∂a/∂r (gravity gradients and the SRP gradient; the slow turn of the cruise
frame with r — relative size |a_acs|/|r_⊙| — is neglected), ∂a/∂v = 0, and
∂a/∂q = [a_srp, a_acs C d, s^k e_j] for q = [q_srp, q_acs, c_kj].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.models.vector import cross
from fsw.astro.constants import AU_KM, GM_EARTH_MOON, GM_JUPITER_SYSTEM, GM_MARS, GM_SUN, P_SUN_1AU_N_M2

GM_THIRD = np.array([GM_SUN, GM_EARTH_MOON, GM_JUPITER_SYSTEM])


def srp_coefficient(area_m2: float, mass_kg: float, cr: float) -> float:
    """K = Cr (A/m) P₁AU AU² [km³/s²]: SRP acceleration [km/s²] = K · scale / d² [km]."""
    return cr * area_m2 / mass_kg * P_SUN_1AU_N_M2 * 1e-3 * AU_KM**2


@dataclass(frozen=True)
class ForceParameters:
    """Per-filter constants of the force model (arrays over the N filters of a stack)."""

    srp_coefficient: np.ndarray  # (N,) km³/s²
    acs_nominal: np.ndarray  # (N,) km/s²
    acs_direction: np.ndarray  # (N, 3) unit, cruise body frame
    poly_degree: int | None
    poly_batch_s: np.ndarray  # (N,) s
    poly_origin_s: float = 0.0

    @property
    def n_q(self) -> int:
        return 2 + (0 if self.poly_degree is None else 3 * (self.poly_degree + 1))


def cruise_frame(r: np.ndarray, r_sun: np.ndarray, r_earth: np.ndarray) -> np.ndarray:
    """(N, 3, 3) columns = cruise body x, y, z in ICRF."""
    z = r_sun - r
    z /= np.linalg.norm(z, axis=-1, keepdims=True)
    e = r_earth - r
    x = e - np.sum(e * z, axis=-1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    return np.stack([x, cross(z, x), z], axis=-1)


def acs_direction_icrf(r: np.ndarray, bodies: np.ndarray, params: ForceParameters) -> np.ndarray:
    """Nominal ACS acceleration a_acs C d (N, 3) in ICRF."""
    C = cruise_frame(r, bodies[0], bodies[1])
    return params.acs_nominal[:, None] * np.einsum("nij,nj->ni", C, params.acs_direction)


def acceleration(
    r: np.ndarray,
    q: np.ndarray,
    bodies: np.ndarray,
    s_poly: np.ndarray | None,
    params: ForceParameters,
    partials: bool = True,
    a_acs: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Acceleration a (N, 3), G = ∂a/∂r (N, 3, 3) and ∂a/∂q (N, 3, n_q).

    ``r`` (N, 3) Mars-centred positions, ``q`` (N, n_q) acceleration drivers, ``bodies`` (3, 3)
    Mars-centred positions of Sun, EMB, Jupiter, ``s_poly`` (N,) normalised batch time,
    ``a_acs`` (N, 3) the nominal ACS acceleration if already known for this step.

    Every 1/d² term has the form c (r − b)/|r − b|³ (b = Mars' centre, the Sun, EMB,
    Jupiter; the Sun's gravity and SRP share one term), with gradient
    c (I/|d|³ − 3 d dᵀ/|d|⁵); all of them are evaluated in one batched expression.
    """
    N = r.shape[0]
    scale = 1.0 + q[:, 0]
    b = np.zeros((4, 3))
    b[1:] = bodies
    d = r[:, None, :] - b[None, :, :]  # (N, 4, 3)
    d2 = np.einsum("nki,nki->nk", d, d)
    inv_d3 = 1.0 / (d2 * np.sqrt(d2))
    c = np.empty((N, 4))
    c[:, 0] = -GM_MARS
    c[:, 1] = -GM_SUN + scale * params.srp_coefficient
    c[:, 2] = -GM_EARTH_MOON
    c[:, 3] = -GM_JUPITER_SYSTEM
    w = c * inv_d3
    a = np.einsum("nk,nki->ni", w, d)
    rk3 = np.sqrt(np.einsum("ki,ki->k", bodies, bodies)) ** 3
    a -= (GM_THIRD[:, None] * bodies / rk3[:, None]).sum(axis=0)  # indirect terms
    if a_acs is None:
        a_acs = acs_direction_icrf(r, bodies, params)
    a += (1.0 + q[:, 1])[:, None] * a_acs
    powers = None
    if params.poly_degree is not None:
        coeffs = q[:, 2:].reshape(N, params.poly_degree + 1, 3)
        powers = s_poly[:, None] ** np.arange(params.poly_degree + 1)[None, :]
        a += np.einsum("nk,nkj->nj", powers, coeffs)
    if not partials:
        return a, None, None
    G = -3.0 * np.einsum("nk,nki,nkj->nij", w / d2, d, d)
    G[:, [0, 1, 2], [0, 1, 2]] += w.sum(axis=1)[:, None]
    dadq = np.zeros((N, 3, params.n_q))
    dadq[:, :, 0] = (params.srp_coefficient * inv_d3[:, 1])[:, None] * d[:, 1, :]
    dadq[:, :, 1] = a_acs
    if powers is not None:
        for k in range(params.poly_degree + 1):
            dadq[:, [0, 1, 2], 2 + 3 * k + np.arange(3)] = powers[:, k : k + 1]
    return a, G, dadq

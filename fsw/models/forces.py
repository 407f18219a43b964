"""Onboard force model: accelerations and their partials for a stack of N filters.

Mars-centred ICRF, km and s::

    a = −μ_M r/|r|³                                             Mars point mass
      + Σ_k μ_k [ (r_k − r)/|r_k − r|³ − r_k/|r_k|³ ]           Sun, Earth–Moon barycentre, Jupiter
                                                                (direct and indirect terms)
      + (1 + q_srp) K_srp (r − r_⊙)/|r − r_⊙|³                  cannonball SRP, K = Cr (A/m) P₁AU AU²
      + a_acs (1 + q_acs) C_cruise (d + θ₁ e₁ + θ₂ e₂)          ACS small force, cruise body frame
      + Σ_k c_k ((t − t_b)/T_b)^k                               batched polynomial acceleration

Cruise body frame (solar arrays on the Sun): z towards the Sun, x the component of the Earth
direction across the Sun line, y = z × x; d is the unit nominal net thrust direction in it and
e₁, e₂ two unit vectors across d: θ₁, θ₂ are the small thrust-direction errors, a constant
random bias of 3° per axis in Lubey & Ely 2022 Table 1 ("attitude thruster orientation"). To first
order in θ (the dropped renormalisation changes the magnitude by θ²/2 ≈ 1e-3, far inside the
3 % magnitude bias) the tilted direction is d + θ₁ e₁ + θ₂ e₂.

Partials: G = ∂a/∂r (gravity gradients and the SRP gradient; the slow turn of the cruise
frame with r — relative size |a_acs|/|r_⊙| — is neglected), ∂a/∂v = 0, and
∂a/∂q = [a_srp, a_acs C u, a_acs (1 + q_acs) C e₁, a_acs (1 + q_acs) C e₂, s^k e_j] for
q = [q_srp, q_acs, θ₁, θ₂, c_kj], u = d + θ₁ e₁ + θ₂ e₂.

Every 1/d² term has the form c (r − b)/|r − b|³ (b = Mars' centre, the Sun, EMB, Jupiter; the
Sun's gravity and SRP share one term), with gradient c (I/|d|³ − 3 d dᵀ/|d|⁵): they are all
evaluated in one batched expression (:func:`point_masses`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import AU_KM, GM_EARTH_MOON, GM_JUPITER_SYSTEM, GM_MARS, GM_SUN, P_SUN_1AU_N_M2
from fsw.models.layout import N_Q_FIXED
from fsw.models.vector import cross

GM_THIRD = np.array([GM_SUN, GM_EARTH_MOON, GM_JUPITER_SYSTEM])
_EYE3 = np.eye(3)


def srp_coefficient(area_m2: float, mass_kg: float, cr: float) -> float:
    """K = Cr (A/m) P₁AU AU² [km³/s²]: SRP acceleration [km/s²] = K · scale / d² [km]."""
    return cr * area_m2 / mass_kg * P_SUN_1AU_N_M2 * 1e-3 * AU_KM**2


def tilt_basis(direction: np.ndarray) -> np.ndarray:
    """(N, 2, 3) unit vectors e₁, e₂ across each unit direction d (N, 3), right-handed with d.

    Any orthonormal pair serves: the a-priori of the two tilts is isotropic."""
    d = np.asarray(direction, dtype=float)
    ref = np.where((np.abs(d[:, 0]) < 0.9)[:, None], _EYE3[0], _EYE3[1])
    e1 = cross(d, ref)
    e1 /= np.sqrt(np.vecdot(e1, e1))[:, None]
    return np.stack([e1, cross(d, e1)], axis=1)


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
        return N_Q_FIXED + (0 if self.poly_degree is None else 3 * (self.poly_degree + 1))

    @property
    def acs_body(self) -> np.ndarray:
        """(N, 3, 3) body-frame vectors [d, e₁, e₂] (rows) of each filter's ACS model."""
        cached = self.__dict__.get("_acs_body")
        if cached is None:
            cached = np.concatenate([self.acs_direction[:, None, :], tilt_basis(self.acs_direction)], axis=1)
            object.__setattr__(self, "_acs_body", cached)
        return cached


def cruise_frame(r: np.ndarray, r_sun: np.ndarray, r_earth: np.ndarray) -> np.ndarray:
    """(N, 3, 3) columns = cruise body x, y, z in ICRF."""
    z = r_sun - r
    z /= np.sqrt(np.vecdot(z, z))[..., None]
    e = r_earth - r
    x = e - np.vecdot(e, z)[..., None] * z
    x /= np.sqrt(np.vecdot(x, x))[..., None]
    return np.stack([x, cross(z, x), z], axis=-1)


def cruise_axes(r: np.ndarray, r_sun: np.ndarray, r_earth: np.ndarray) -> np.ndarray:
    """(3, 3) rows = cruise body x, y, z in ICRF at one position r (3,) (scalar arithmetic:
    one small frame costs less this way than as array operations)."""
    zx, zy, zz = (float(c) for c in r_sun - r)
    n = math.sqrt(zx * zx + zy * zy + zz * zz)
    zx, zy, zz = zx / n, zy / n, zz / n
    ex, ey, ez = (float(c) for c in r_earth - r)
    p = ex * zx + ey * zy + ez * zz
    xx, xy, xz = ex - p * zx, ey - p * zy, ez - p * zz
    n = math.sqrt(xx * xx + xy * xy + xz * xz)
    xx, xy, xz = xx / n, xy / n, xz / n
    return np.array(((xx, xy, xz), (zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx), (zx, zy, zz)))


def acs_terms(r: np.ndarray, bodies: np.ndarray, q: np.ndarray, params: ForceParameters) -> tuple[np.ndarray, np.ndarray]:
    """ACS acceleration (N, 3) in ICRF and its partials (N, 3, 3) w.r.t. q_acs, θ₁, θ₂.

    ``bodies`` (3, 3): Mars-centred Sun, EMB, Jupiter; ``q`` (N, n_q) drivers. The cruise
    frame is evaluated at the first filter's position for the whole stack: the filters of a
    bank lie within ~1e3 km of one another, which turns the Sun and Earth directions (≥ 1e8 km
    away) by < 1e-5 rad, i.e. changes the ~5e-12 km/s² ACS acceleration by < 1e-16 km/s²."""
    Cb = np.matmul(params.acs_body, cruise_axes(r[0], bodies[0], bodies[1]))  # rows: C d, C e₁, C e₂ (N, 3, 3)
    u = Cb[:, 0] + q[:, 2:3] * Cb[:, 1] + q[:, 3:4] * Cb[:, 2]
    a_nom = params.acs_nominal[:, None]
    gain = a_nom * (1.0 + q[:, 1:2])
    part = np.empty((r.shape[0], 3, 3))
    part[:, :, 0] = a_nom * u
    part[:, :, 1:3] = gain[:, :, None] * Cb[:, 1:3].transpose(0, 2, 1)
    return gain * u, part


def centres(bodies: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The four 1/d² centres (Mars' centre, Sun, EMB, Jupiter) (4, 3) and the indirect
    acceleration −Σ μ_k r_k/|r_k|³ (3,) at one epoch, from Mars-centred ``bodies`` (3, 3)."""
    b = np.zeros((4, 3))
    b[1:] = bodies
    rk2 = np.vecdot(bodies, bodies)
    return b, -((GM_THIRD / (rk2 * np.sqrt(rk2))) @ bodies)


def point_mass_coefficients(q: np.ndarray, params: ForceParameters) -> np.ndarray:
    """c (N, 4) of the four c (r − b)/|r − b|³ terms for drivers q (N, n_q)."""
    c = np.empty((q.shape[0], 4))
    c[:, 0] = -GM_MARS
    c[:, 1] = -GM_SUN + (1.0 + q[:, 0]) * params.srp_coefficient
    c[:, 2] = -GM_EARTH_MOON
    c[:, 3] = -GM_JUPITER_SYSTEM
    return c


def point_masses(r: np.ndarray, b: np.ndarray, coeff: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Σ_k c_k d_k/|d_k|³ (N, 3) with d_k = r − b_k; also d (N, 4, 3), |d|² (N, 4), c/|d|³ (N, 4)."""
    d = r[:, None, :] - b
    d2 = np.vecdot(d, d)
    w = coeff / (d2 * np.sqrt(d2))
    return np.matmul(w[:, None, :], d)[:, 0, :], d, d2, w


def point_mass_gradient(d: np.ndarray, d2: np.ndarray, w: np.ndarray) -> np.ndarray:
    """G = Σ_k c_k (I/|d_k|³ − 3 d_k d_kᵀ/|d_k|⁵) (N, 3, 3)."""
    G = np.matmul(d.transpose(0, 2, 1) * (-3.0 * w / d2)[:, None, :], d)
    G += np.add.reduce(w, axis=1)[:, None, None] * _EYE3
    return G


def poly_powers(s_poly: np.ndarray, degree: int) -> np.ndarray:
    """(N, degree + 1) powers s^k of the normalised batch time."""
    return s_poly[:, None] ** np.arange(degree + 1)


def acceleration(
    r: np.ndarray,
    q: np.ndarray,
    bodies: np.ndarray,
    s_poly: np.ndarray | None,
    params: ForceParameters,
    partials: bool = True,
    acs: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Acceleration a (N, 3), G = ∂a/∂r (N, 3, 3) and ∂a/∂q (N, 3, n_q).

    ``r`` (N, 3) Mars-centred positions, ``q`` (N, n_q) acceleration drivers, ``bodies`` (3, 3)
    Mars-centred positions of Sun, EMB, Jupiter, ``s_poly`` (N,) normalised batch time,
    ``acs`` the :func:`acs_terms` of this step if already known.
    """
    N = r.shape[0]
    b, indirect = centres(bodies)
    a, d, d2, w = point_masses(r, b, point_mass_coefficients(q, params))
    a += indirect
    a_acs, acs_part = acs_terms(r, bodies, q, params) if acs is None else acs
    a += a_acs
    powers = None
    if params.poly_degree is not None:
        if s_poly is None:
            raise ValueError("a polynomial acceleration needs the normalised batch time s_poly")
        coeffs = q[:, N_Q_FIXED:].reshape(N, params.poly_degree + 1, 3)
        powers = poly_powers(s_poly, params.poly_degree)
        a += np.einsum("nk,nkj->nj", powers, coeffs)
    if not partials:
        return a, None, None
    G = point_mass_gradient(d, d2, w)
    dadq = np.zeros((N, 3, params.n_q))
    dadq[:, :, 0] = (params.srp_coefficient / (d2[:, 1] * np.sqrt(d2[:, 1])))[:, None] * d[:, 1, :]
    dadq[:, :, 1:N_Q_FIXED] = acs_part
    if powers is not None:
        for k in range(powers.shape[1]):
            dadq[:, [0, 1, 2], N_Q_FIXED + 3 * k + np.arange(3)] = powers[:, k : k + 1]
    return a, G, dadq

"""B-plane targeting of a hyperbolic approach: B·R, B·T and the epoch of closest approach.

The standard B-plane (Kizner 1961; Vallado, *Fundamentals of Astrodynamics*, §12.4): for a
Mars-centred state (r, v) on a hyperbola with gravitational parameter μ,

* energy ε = v²/2 − μ/r > 0, semi-major axis a = −μ/(2ε), v∞ = √(2ε);
* angular momentum h = r × v, eccentricity vector e = ((v² − μ/r) r − (r·v) v)/μ, e = |e|;
* incoming asymptote Ŝ = ê/e + (√(e² − 1)/e) (ĥ × ê) (the direction of the velocity at −∞);
* B = b (Ŝ × ĥ), with b = |a| √(e² − 1) = h / v∞;
* T̂ = Ŝ × k̂ / |Ŝ × k̂|, R̂ = Ŝ × T̂, with k̂ the **Mars pole** (IAU 2009, J2000 RA/Dec), so T̂
  lies in Mars's equator — the Mars-mean-equator B-plane of Mars-approach navigation.

The epoch of closest approach follows from the hyperbolic anomaly F at the state:
sinh F = (r·v) / (e √(μ|a|)), M = e sinh F − F, n = √(μ/|a|³), t_p = t − M/n.

The 3×6 Jacobian ∂(B·R, B·T, t_p)/∂(r, v) is the complex-step derivative (Squire & Trapp 1998):
every operation above is analytic, so Im f(x + i h eₖ)/h is the exact k-th column to rounding,
with no subtraction error — and independent of the central differences the tests check it with.
The FSW evaluates it in one compiled call (:mod:`fsw.kernels.bplane`, the formulas below on
scalars); :func:`_bplane_values` is the numpy form, which gives the ground the truth's B-plane
without a compiler and the tests the kernel's reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import GM_MARS
from fsw.astro.mars import MARS_POLE_DEC_DEG, MARS_POLE_RA_DEG
from fsw.kernels import on_first_call
from fsw.kernels.codes import BPLANE_DEGENERATE, BPLANE_OK

bplane_complex_step = on_first_call(globals(), "bplane_complex_step", "fsw.kernels.bplane")


def mars_pole() -> np.ndarray:
    """Unit vector of Mars's north pole in ICRF (IAU 2009 J2000 values)."""
    ra, dec = math.radians(MARS_POLE_RA_DEG), math.radians(MARS_POLE_DEC_DEG)
    return np.array([math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)])


class NotHyperbolic(ValueError):
    """The state is bound (ε ≤ 0) or degenerate: it has no B-plane."""


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # no conjugation: the complex step needs the analytic continuation of a·b
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _unit(a: np.ndarray) -> np.ndarray:
    return a / np.sqrt(_dot(a, a))


def _bplane_values(x: np.ndarray, mu: float, pole: np.ndarray) -> np.ndarray:
    """(B·R [km], B·T [km], t_p − t [s], v∞ [km/s]) of the 6-state ``x`` (real or complex)."""
    r, v = x[0:3], x[3:6]
    rmag = np.sqrt(_dot(r, r))
    v2 = _dot(v, v)
    energy = v2 / 2.0 - mu / rmag
    a = -mu / (2.0 * energy)
    h = _cross(r, v)
    rv = _dot(r, v)
    evec = ((v2 - mu / rmag) * r - rv * v) / mu
    e = np.sqrt(_dot(evec, evec))
    e_hat, h_hat = evec / e, _unit(h)
    s_hat = e_hat / e + np.sqrt(e * e - 1.0) / e * _cross(h_hat, e_hat)
    b = -a * np.sqrt(e * e - 1.0)
    bvec = b * _cross(s_hat, h_hat)
    t_hat = _unit(_cross(s_hat, pole))
    r_hat = _cross(s_hat, t_hat)
    sinh_f = rv / (e * np.sqrt(-mu * a))
    f = np.arcsinh(sinh_f)
    n = np.sqrt(mu / (-a) ** 3)
    return np.array([_dot(bvec, r_hat), _dot(bvec, t_hat), -(e * sinh_f - f) / n, np.sqrt(2.0 * energy)])


@dataclass(frozen=True, slots=True)
class BPlaneTarget:
    """B-plane coordinates of one state and their covariance."""

    b_dot_r_km: float
    b_dot_t_km: float
    periapsis_s: float  # epoch of closest approach, TDB seconds past J2000
    v_inf_km_s: float
    covariance_km2: np.ndarray  # 2×2 covariance of (B·R, B·T)
    periapsis_sigma_s: float


def bplane_values(position_km: np.ndarray, velocity_km_s: np.ndarray, mu: float = GM_MARS,
                  pole: np.ndarray | None = None) -> np.ndarray:
    """(B·R, B·T, t_p − t, v∞) of one state, in numpy (the ground's B-plane of the truth: no
    compiled kernel in a ground tool). Raises :class:`NotHyperbolic`."""
    k = mars_pole() if pole is None else np.asarray(pole, dtype=float)
    x = np.concatenate([np.asarray(position_km, dtype=float), np.asarray(velocity_km_s, dtype=float)])
    r = float(np.linalg.norm(x[0:3]))
    if r <= 0.0 or float(x[3:6] @ x[3:6]) / 2.0 - mu / r <= 0.0:
        raise NotHyperbolic("the state is bound to Mars (energy ≤ 0)")
    with np.errstate(all="raise"):
        try:
            values = _bplane_values(x, mu, k)
        except FloatingPointError as exc:
            raise NotHyperbolic(f"degenerate hyperbola ({exc})") from None
    if not np.all(np.isfinite(values)):
        raise NotHyperbolic("degenerate hyperbola")
    return values


def bplane_jacobian(position_km: np.ndarray, velocity_km_s: np.ndarray, mu: float = GM_MARS,
                    pole: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(values, J): values = (B·R, B·T, t_p − t, v∞) and J = ∂(B·R, B·T, t_p − t)/∂(r, v), 3×6,
    by the complex step (see the module docstring) in one compiled call
    (:func:`fsw.kernels.bplane.bplane_complex_step`). Raises :class:`NotHyperbolic`."""
    k = mars_pole() if pole is None else np.asarray(pole, dtype=float)
    x = np.concatenate([np.asarray(position_km, dtype=float), np.asarray(velocity_km_s, dtype=float)])
    values, jac = np.empty(4), np.empty((3, 6))
    try:
        code = bplane_complex_step(x, float(mu), np.ascontiguousarray(k, dtype=float), values, jac)
    except ZeroDivisionError:  # an exact zero e, |h| or |Ŝ × k̂|: as the numpy form's division error
        code = BPLANE_DEGENERATE
    if code != BPLANE_OK:
        raise NotHyperbolic("the state is not on a hyperbola about Mars (not finite, bound, radial or degenerate)")
    return values, jac


def bplane_target(t_s: float, position_km: np.ndarray, velocity_km_s: np.ndarray, P: np.ndarray,
                  mu: float = GM_MARS, pole: np.ndarray | None = None) -> BPlaneTarget:
    """B·R, B·T and closest approach of a state with covariance ``P`` (≥ 6×6, position and
    velocity first), the covariance mapped linearly: C = J P₆ Jᵀ."""
    values, jac = bplane_jacobian(position_km, velocity_km_s, mu, pole)
    cov = jac @ np.asarray(P, dtype=float)[0:6, 0:6] @ jac.T
    cov = 0.5 * (cov + cov.T)
    return BPlaneTarget(
        b_dot_r_km=float(values[0]), b_dot_t_km=float(values[1]), periapsis_s=float(t_s + values[2]),
        v_inf_km_s=float(values[3]), covariance_km2=cov[0:2, 0:2],
        periapsis_sigma_s=float(math.sqrt(max(cov[2, 2], 0.0))),
    )

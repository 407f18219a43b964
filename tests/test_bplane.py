"""B-plane targeting (fsw/models/bplane.py) against an independently built hyperbola."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fsw.astro.constants import GM_MARS
from fsw.models.bplane import NotHyperbolic, bplane_jacobian, bplane_target, mars_pole


def _rotation(a: float, b: float, c: float) -> np.ndarray:
    def rz(t: float) -> np.ndarray:
        return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])

    def rx(t: float) -> np.ndarray:
        return np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])

    return rz(a) @ rx(b) @ rz(c)


def _hyperbola(e: float, a_abs: float, nu: float, q: np.ndarray):
    """State at true anomaly ``nu`` and the B vector built from the geometry of the hyperbola:
    the incoming asymptote passes through the centre (|a| e, 0) of the perifocal frame, and B is
    the perpendicular from the focus to that line."""
    p = a_abs * (e * e - 1.0)
    r = p / (1.0 + e * math.cos(nu)) * np.array([math.cos(nu), math.sin(nu), 0.0])
    v = math.sqrt(GM_MARS / p) * np.array([-math.sin(nu), e + math.cos(nu), 0.0])
    nu_inf = math.acos(-1.0 / e)
    s_hat = -np.array([math.cos(-nu_inf), math.sin(-nu_inf), 0.0])  # inbound along −r̂ at ν = −ν∞
    centre = np.array([a_abs * e, 0.0, 0.0])
    b_vec = centre - (centre @ s_hat) * s_hat
    f = 2.0 * math.atanh(math.sqrt((e - 1.0) / (e + 1.0)) * math.tan(nu / 2.0))
    dt_since_periapsis = (e * math.sinh(f) - f) / math.sqrt(GM_MARS / a_abs**3)
    return q @ r, q @ v, q @ s_hat, q @ b_vec, dt_since_periapsis


@pytest.mark.parametrize("e,a_abs,nu,angles", [
    (1.8, 4900.0, -2.0, (0.3, 0.7, -1.1)),
    (3.5, 2000.0, -1.0, (2.0, -0.4, 0.5)),
    (1.2, 20000.0, -2.4, (-1.0, 1.2, 2.9)),
])
def test_bplane_matches_the_geometry_of_a_hand_built_hyperbola(e, a_abs, nu, angles):
    q = _rotation(*angles)
    r, v, s_hat, b_vec, dt = _hyperbola(e, a_abs, nu, q)
    k = mars_pole()
    t_hat = np.cross(s_hat, k) / np.linalg.norm(np.cross(s_hat, k))
    r_hat = np.cross(s_hat, t_hat)
    tgt = bplane_target(1000.0, r, v, np.eye(6))
    assert np.linalg.norm(b_vec) == pytest.approx(a_abs * math.sqrt(e * e - 1.0), rel=1e-12)
    assert tgt.b_dot_r_km == pytest.approx(b_vec @ r_hat, abs=1e-6 * a_abs)
    assert tgt.b_dot_t_km == pytest.approx(b_vec @ t_hat, abs=1e-6 * a_abs)
    assert tgt.periapsis_s == pytest.approx(1000.0 - dt, abs=1e-4)
    assert tgt.v_inf_km_s == pytest.approx(math.sqrt(GM_MARS / a_abs), rel=1e-12)


def test_jacobian_matches_central_differences():
    r, v, *_ = _hyperbola(2.2, 3500.0, -1.7, _rotation(0.4, 1.1, -0.3))
    values, jac = bplane_jacobian(r, v)
    x = np.concatenate([r, v])
    steps = [1e-2] * 3 + [1e-6] * 3  # km, km/s
    for j in range(6):
        dx = np.zeros(6)
        dx[j] = steps[j]
        hi, _ = bplane_jacobian((x + dx)[:3], (x + dx)[3:])
        lo, _ = bplane_jacobian((x - dx)[:3], (x - dx)[3:])
        fd = (hi[:3] - lo[:3]) / (2 * steps[j])
        np.testing.assert_allclose(jac[:, j], fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(jac[:, j])))


def test_covariance_is_mapped_through_the_jacobian():
    r, v, *_ = _hyperbola(1.9, 5000.0, -2.1, _rotation(1.0, 0.2, 0.1))
    rng = np.random.default_rng(3)
    a = rng.normal(size=(7, 7))
    P = a @ a.T
    _, jac = bplane_jacobian(r, v)
    tgt = bplane_target(0.0, r, v, P)
    full = jac @ P[:6, :6] @ jac.T
    np.testing.assert_allclose(tgt.covariance_km2, full[:2, :2], rtol=1e-12)
    assert tgt.periapsis_sigma_s == pytest.approx(math.sqrt(full[2, 2]), rel=1e-12)


def test_a_bound_state_has_no_bplane():
    r = np.array([10000.0, 0.0, 0.0])
    v = np.array([0.0, 1.0, 0.0])  # below escape speed (2.93 km/s at 10 000 km)
    with pytest.raises(NotHyperbolic):
        bplane_target(0.0, r, v, np.eye(6))


def _numpy_complex_step(x: np.ndarray) -> np.ndarray:
    """The Jacobian by the complex step through the numpy form (``_bplane_values``), all six columns at once."""
    from fsw.models.bplane import _bplane_values

    step = 1e-30 * max(1.0, float(np.max(np.abs(x))))
    xc = np.repeat(x.astype(complex)[:, None], 6, axis=1)
    xc[np.arange(6), np.arange(6)] += 1j * step
    return np.imag(_bplane_values(xc, GM_MARS, mars_pole()[:, None])[:3]) / step


def test_compiled_targeting_is_the_numpy_form_to_rounding():
    """The FSW's compiled values and Jacobian against the numpy form (values) and the numpy form's
    own complex step (Jacobian), on 2,000 random hyperbolas: e from 1.01 to 20, |a| from 500 to
    50,000 km, anywhere on the incoming leg, any orientation."""
    from fsw.models.bplane import bplane_values

    rng = np.random.default_rng(11)
    for _ in range(2000):
        e, a_abs = 1.0 + 10.0 ** rng.uniform(-2, 1.3), 10.0 ** rng.uniform(2.7, 4.7)
        nu_inf = math.acos(-1.0 / e)
        r, v, *_ = _hyperbola(e, a_abs, -rng.uniform(0.0, 0.98) * nu_inf, _rotation(*rng.uniform(-math.pi, math.pi, 3)))
        values, jac = bplane_jacobian(r, v)
        want = bplane_values(r, v)
        np.testing.assert_allclose(values, want, rtol=1e-13, atol=1e-9 * a_abs * 1e-3)
        ref = _numpy_complex_step(np.concatenate([r, v]))
        for j in range(6):
            np.testing.assert_allclose(jac[:, j], ref[:, j], rtol=1e-11, atol=1e-12 * np.max(np.abs(ref[:, j])))


@pytest.mark.parametrize("case", ["bound", "radial", "exactly radial", "at the centre", "NaN position",
                                  "infinite velocity", "infinite position"])
def test_compiled_targeting_refuses_what_has_no_bplane(case):
    """Refused as the numpy form refuses them (NotHyperbolic), whichever way the kernel meets
    them: its checks, or a division by an exact zero."""
    from fsw.models.bplane import bplane_values

    r, v = {
        "bound": ([10000.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        "radial": ([1.0e5, 2.0e4, -3.0e4], list(-4.0 * np.array([1.0e5, 2.0e4, -3.0e4]) / np.linalg.norm([1.0e5, 2.0e4, -3.0e4]))),
        "exactly radial": ([1.0e5, 0.0, 0.0], [-5.0, 0.0, 0.0]),  # h = 0 to the bit
        "at the centre": ([0.0, 0.0, 0.0], [0.0, 5.0, 0.0]),
        "NaN position": ([np.nan, 1.0e5, 0.0], [1.0, 2.0, 3.0]),
        "infinite velocity": ([1.0e5, 0.0, 0.0], [np.inf, 0.0, 0.0]),
        "infinite position": ([np.inf, 1.0e5, 0.0], [-3.0, 1.0, 0.0]),
    }[case]
    r, v = np.array(r), np.array(v)
    with pytest.raises(NotHyperbolic):
        bplane_jacobian(r, v)
    with pytest.raises(NotHyperbolic):
        bplane_values(r, v)

"""Truth propagator against an independent universal-variable Kepler solution (Mars only)."""

import math

import numpy as np
import pytest

from fsw.astro.constants import GM_MARS
from sim.dynamics.config import ForceModelConfig
from sim.dynamics.propagator import propagate
from sim.dynamics.stochastic import StochasticRealisation

MARS_ONLY = ForceModelConfig(include_sun=False, include_earth=False, include_jupiter=False, srp_enabled=False,
                             acs_nominal_km_s2=0.0).without_dispersions()


def _stumpff(z):
    if z > 1e-8:
        s = math.sqrt(z)
        return (1 - math.cos(s)) / z, (s - math.sin(s)) / s**3
    if z < -1e-8:
        s = math.sqrt(-z)
        return (math.cosh(s) - 1) / -z, (math.sinh(s) - s) / s**3
    return 0.5, 1.0 / 6.0


def kepler_universal(r0, v0, dt, mu):
    """Two-body state after dt (Curtis, Algorithms 3.3/3.4: universal anomaly and f, g)."""
    r0n = np.linalg.norm(r0)
    vr0 = np.dot(r0, v0) / r0n
    alpha = 2 / r0n - np.dot(v0, v0) / mu
    smu = math.sqrt(mu)
    chi = smu * abs(alpha) * dt if alpha > 0 else smu * dt / r0n
    for _ in range(200):
        z = alpha * chi * chi
        C, S = _stumpff(z)
        F = r0n * vr0 / smu * chi * chi * C + (1 - alpha * r0n) * chi**3 * S + r0n * chi - smu * dt
        dF = r0n * vr0 / smu * chi * (1 - alpha * chi * chi * S) + (1 - alpha * r0n) * chi * chi * C + r0n
        step = F / dF
        chi -= step
        if abs(step) < 1e-13 * max(1.0, abs(chi)):
            break
    z = alpha * chi * chi
    C, S = _stumpff(z)
    f = 1 - chi * chi / r0n * C
    g = dt - chi**3 / smu * S
    r = f * r0 + g * v0
    rn = np.linalg.norm(r)
    fdot = smu / (rn * r0n) * (alpha * chi**3 * S - chi)
    gdot = 1 - chi * chi / rn * C
    return r, fdot * r0 + gdot * v0


@pytest.mark.parametrize("x0", [
    np.array([20000.0, 3000.0, -1000.0, -0.3, 1.35, 0.2]),  # ellipse, e ~ 0.3
    np.array([-8.0e5, 3.0e5, 1.0e5, 2.5, -0.8, -0.3]),  # hyperbola, v_inf ~ 2.7 km/s
])
def test_mars_only_matches_kepler_over_10_days(x0):
    t0 = 5.9e8
    t1 = t0 + 10 * 86400.0
    real = StochasticRealisation.nominal(MARS_ONLY, t0, t1)
    traj = propagate(x0, t0, t1, MARS_ONLY, real)
    assert traj.n_segments == 10  # restarted at every daily batch edge
    for t in np.linspace(t0, t1, 11):
        r, v = kepler_universal(x0[:3], x0[3:], t - t0, GM_MARS)
        x = traj.state(t)
        assert np.linalg.norm(x[:3] - r) < 1e-3  # < 1 m
        assert np.linalg.norm(x[3:] - v) < 1e-8  # < 10 um/s


def test_backward_then_forward_returns_to_start():
    x0 = np.array([-8.0e5, 3.0e5, 1.0e5, 2.5, -0.8, -0.3])
    t0, t1 = 5.9e8, 5.9e8 + 5 * 86400.0
    real = StochasticRealisation.nominal(MARS_ONLY, t0, t1)
    fwd = propagate(x0, t0, t1, MARS_ONLY, real)
    back = propagate(fwd.final_state, t1, t0, MARS_ONLY, real)
    assert np.linalg.norm(back.final_state[:3] - x0[:3]) < 1e-4
    assert np.allclose(back.state(t0 + 86400.0 * 2.5), fwd.state(t0 + 86400.0 * 2.5), atol=1e-4, rtol=0)

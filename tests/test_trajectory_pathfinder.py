"""The pathfinder-cruise trajectory: Lambert solver against independent checks, and the design arc."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fsw.astro.constants import AU_KM, GM_SUN, SECONDS_PER_DAY
from fsw.astro.ephemeris import default_ephemeris
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.dynamics.stochastic import DynamicsError
from sim.trajectories import pathfinder
from sim.trajectories.design import arc_span, initial_state
from sim.trajectories.lambert import LambertError, kepler, lambert

MU_EARTH = 398600.0


def _two_body(r0, v0, dt, mu):
    """Independent propagation: scipy DOP853 on r'' = -mu r/|r|^3."""
    def f(_t, y):
        r = y[:3]
        return np.concatenate([y[3:], -mu * r / np.linalg.norm(r) ** 3])
    sol = solve_ivp(f, (0.0, dt), np.concatenate([r0, v0]), method="DOP853", rtol=1e-13, atol=1e-9)
    return sol.y[:3, -1], sol.y[3:, -1]


def test_lambert_reproduces_curtis_example_5_2():
    # Curtis, Orbital Mechanics for Engineering Students, Example 5.2 (published values)
    v1, v2 = lambert([5000.0, 10000.0, 2100.0], [-14600.0, 2500.0, 7000.0], 3600.0, MU_EARTH)
    np.testing.assert_allclose(v1, [-5.9925, 1.9254, 3.2456], atol=2e-4)
    np.testing.assert_allclose(v2, [-3.3125, -4.1966, -0.38529], atol=2e-4)


@pytest.mark.parametrize("tof_days", [120.0, 212.0, 300.0])
def test_lambert_earth_mars_hits_the_target_under_independent_propagation(tof_days):
    eph = default_ephemeris()
    t1 = -97_000_000.0
    r1, _ = eph.state("earth", t1, "sun")
    r2, _ = eph.state("mars", t1 + tof_days * SECONDS_PER_DAY, "sun")
    v1, v2 = lambert(r1, r2, tof_days * SECONDS_PER_DAY, GM_SUN)
    r_end, v_end = _two_body(r1, v1, tof_days * SECONDS_PER_DAY, GM_SUN)
    assert np.linalg.norm(r_end - r2) < 1.0  # km, over ~1.5 AU
    np.testing.assert_allclose(v_end, v2, atol=1e-7)
    h = np.cross(r1, v1)
    assert h[2] > 0  # prograde


def test_kepler_matches_independent_integration_elliptic_and_hyperbolic():
    r0 = np.array([7000.0, -1200.0, 300.0])
    for v0 in (np.array([1.0, 7.4, 0.5]), np.array([0.5, 11.8, 1.0])):
        r, v = kepler(r0, v0, 20_000.0, MU_EARTH)
        r_ref, v_ref = _two_body(r0, v0, 20_000.0, MU_EARTH)
        np.testing.assert_allclose(r, r_ref, atol=1e-5)
        np.testing.assert_allclose(v, v_ref, atol=1e-9)


def test_lambert_rejects_degenerate_geometry():
    with pytest.raises(LambertError):
        lambert([1e8, 0, 0], [2e8, 0, 0], 1e7, GM_SUN)
    with pytest.raises(LambertError):
        lambert([1e8, 0, 0], [0, 1e8, 0], -5.0, GM_SUN)
    with pytest.raises(LambertError):
        lambert([np.nan, 0, 0], [0, 1e8, 0], 1e7, GM_SUN)


CFG = TrajectoryConfig(kind="pathfinder-cruise", span_days=126.0)
FORCES = ForceModelConfig(acs_nominal_km_s2=0.0, srp_area_m2=5.5, srp_mass_kg=890.0)


def test_transfer_is_type_one_with_pathfinder_like_energy():
    t_l, r_e, v1, t_a = pathfinder.transfer_conic(CFG)
    assert (t_a - t_l) / SECONDS_PER_DAY == pytest.approx(212.4, abs=0.1)
    _, v_e = default_ephemeris().state("earth", t_l, "sun")
    c3 = float(np.linalg.norm(v1 - v_e) ** 2)
    assert 8.0 < c3 < 16.0  # km^2/s^2 (Pathfinder's launch C3 was ~13)
    r_m, _ = default_ephemeris().state("mars", t_a, "sun")
    angle = math.degrees(math.acos(np.dot(r_e, r_m) / np.linalg.norm(r_e) / np.linalg.norm(r_m)))
    assert 90.0 < angle < 180.0  # Type I: the short way


def test_design_arc_starts_near_earth_and_heads_for_mars():
    t0, x0 = initial_state(CFG, FORCES)
    start, end = arc_span(CFG)
    assert t0 == start and (end - start) == pytest.approx(126 * SECONDS_PER_DAY)
    eph = default_ephemeris()
    earth, _ = eph.state("earth", t0, "mars")
    d_earth = np.linalg.norm(x0[:3] - earth)
    assert 1e5 < d_earth < 5e5  # one day after launch
    # the correction for the Earth's pull is of the size of the escape speed there
    conic = pathfinder.conic_state(CFG, t0)
    sun, vsun = eph.state("sun", t0, "mars")
    dv = np.linalg.norm(x0[3:] - (conic[3:] + vsun))
    assert 0.05 < dv < math.sqrt(2 * MU_EARTH / d_earth)
    assert pathfinder.design_miss_km(CFG, FORCES) < 1.0


def test_cruise_must_end_before_the_aim_point():
    with pytest.raises(DynamicsError):
        arc_span(TrajectoryConfig(kind="pathfinder-cruise", span_days=205.0))


def test_insight_default_is_unchanged_by_the_dispatch():
    from sim.trajectories.insight import insight_initial_state
    t0, x0 = initial_state(TrajectoryConfig(), ForceModelConfig())
    t1, x1 = insight_initial_state(TrajectoryConfig(), ForceModelConfig())
    assert t0 == t1 and np.array_equal(x0, x1)
    assert np.linalg.norm(x0[:3]) < 0.1 * AU_KM

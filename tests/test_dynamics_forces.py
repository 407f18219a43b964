"""Truth force terms: hand-computed SRP, indirect third-body term, ACS frame, burns."""

import math

import numpy as np
import pytest

from fsw.astro.constants import AU_KM, GM_MARS
from fsw.astro.ephemeris import default_ephemeris
from sim.dynamics.config import ForceModelConfig, ManeuverConfig
from sim.dynamics.forces import acceleration_components, make_rhs
from sim.dynamics.propagator import make_table, propagate
from sim.dynamics.stochastic import DynamicsError, StochasticRealisation

T = 5.9e8  # 2018-09-12


@pytest.fixture(scope="module")
def table():
    return make_table(T - 5 * 86400, T + 5 * 86400)


def test_srp_magnitude_by_hand(table):
    f = ForceModelConfig()
    r = np.array([2.0e6, -1.0e6, 5.0e5])
    d = np.linalg.norm(r - default_ephemeris().position("sun", T, "mars"))
    # 1361 W/m^2 / c = 4.5398e-6 N/m^2; x Cr 1.3 x 8 m^2 / 694 kg = 6.8031e-8 m/s^2 at 1 AU.
    hand = 1361.0 / 299792458.0 * 1.3 * 8.0 / 694.0 * 1e-3 / (d / AU_KM) ** 2
    a = acceleration_components(f, table, T, r, srp_scale=1.1)["srp"]
    assert np.linalg.norm(a) == pytest.approx(1.1 * hand, rel=1e-9)
    assert 2e-11 < hand < 5e-11  # ~1.4 AU: a few 1e-11 km/s^2
    sun_dir = default_ephemeris().position("sun", T, "mars") - r
    assert np.dot(a, sun_dir) / (np.linalg.norm(a) * np.linalg.norm(sun_dir)) == pytest.approx(-1.0, abs=1e-9)


def test_third_bodies_vanish_at_mars_centre_and_are_small(table):
    f = ForceModelConfig()
    # Near Mars' centre the direct and indirect terms leave the tide: between 1 and 2
    # GM delta / R^3 depending on the offset direction (Hill's approximation).
    from fsw.astro.constants import GM_EARTH_MOON, GM_JUPITER_SYSTEM, GM_SUN
    P = table.positions(T)
    for delta in (1e-3, 1.0):
        comps = acceleration_components(f, table, T, np.array([delta, 0.0, 0.0]))
        for body, gm, k in (("sun", GM_SUN, 0), ("earth", GM_EARTH_MOON, 1), ("jupiter", GM_JUPITER_SYSTEM, 2)):
            ratio = np.linalg.norm(comps[body]) / (gm * delta / np.linalg.norm(P[k]) ** 3)
            assert 0.99 < ratio < 2.01
    comps = acceleration_components(f, table, T, np.array([5e6, 0.0, 0.0]))
    # Solar tide at 5e6 km from Mars (~1.4 AU): between 1 and 2 GM_sun d / R^3 ~ 0.7-1.4e-7 km/s^2.
    assert 6e-8 < np.linalg.norm(comps["sun"]) < 1.6e-7


def test_fast_rhs_equals_vector_form(table):
    f = ForceModelConfig()
    acs = np.array([1e-12, -2e-12, 4e-12])
    rhs = make_rhs(f, table, 1.07, acs)
    for r in (np.array([4000.0, 1000.0, -500.0]), np.array([-3e6, 8e6, 4e6])):
        y = np.concatenate([r, [1.0, 2.0, 3.0]])
        total = sum(acceleration_components(f, table, T, r, 1.07, acs).values())
        assert np.allclose(rhs(T, y)[3:], total, rtol=1e-12, atol=1e-22)
        assert np.allclose(rhs(T, y)[:3], [1.0, 2.0, 3.0])
    y = np.array([4000.0, 0.0, 0.0, 0, 0, 0])
    assert rhs(T, y)[3] == pytest.approx(-GM_MARS / 4000.0**2, rel=1e-6)


def test_acs_frame_and_magnitude(table):
    f = ForceModelConfig()
    r = np.array([-3e6, 8e6, 4e6])
    body = np.array([0.0, 0.0, 5e-12])  # along body z = towards the Sun
    a = acceleration_components(f, table, T, r, acs_body=body)["acs"]
    sun = table.positions(T)[0] - r
    assert np.allclose(a, 5e-12 * sun / np.linalg.norm(sun), rtol=1e-9, atol=1e-24)


def test_burn_is_applied_at_its_epoch():
    f = ForceModelConfig(include_sun=False, include_earth=False, include_jupiter=False, srp_enabled=False,
                         acs_nominal_km_s2=0.0,
                         maneuvers=(ManeuverConfig(epoch_offset_days=1.5, dv_km_s=(1e-3, 0.0, -2e-3)),))
    f = f.without_dispersions()
    t0, t1 = T, T + 3 * 86400
    real = StochasticRealisation.nominal(f, t0, t1)
    x0 = np.array([-8.0e5, 3.0e5, 1.0e5, 2.5, -0.8, -0.3])
    traj = propagate(x0, t0, t1, f, real)
    tm = t0 + 1.5 * 86400
    dv = traj.state(tm)[3:] - traj.state(tm - 1e-3)[3:]
    assert np.allclose(dv, [1e-3, 0.0, -2e-3], atol=1e-9)
    back = propagate(traj.final_state, t1, t0, f, real)
    assert np.linalg.norm(back.final_state[:3] - x0[:3]) < 1e-3


def test_bad_inputs():
    f = ForceModelConfig()
    real = StochasticRealisation.nominal(f, T, T + 86400)
    with pytest.raises(DynamicsError):
        propagate(np.zeros(5), T, T + 10, f, real)
    with pytest.raises(DynamicsError):
        propagate(np.full(6, np.nan), T, T + 10, f, real)
    with pytest.raises(DynamicsError):
        propagate(np.ones(6) * 1e6, T, T + 3 * 86400, f, real)  # realisation too short
    with pytest.raises(DynamicsError):
        StochasticRealisation.draw(f, T, T + 86400, None)  # dispersions need a Generator
    with pytest.raises(ValueError):
        ForceModelConfig(acs_directions_body=((0.0, 0.0, 0.0),))
    assert math.isfinite(real.srp_scale_at(T))

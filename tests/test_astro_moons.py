"""Phobos/Deimos onboard: the published mean elements give the published periods, planes and precession."""

import math

import numpy as np
import pytest

from fsw.astro.frames import radec_to_unit
from fsw.astro.moons import MOONS, MoonError, moon_state


@pytest.mark.parametrize("name,period_d", [("phobos", 0.3189), ("deimos", 1.2624)])
def test_period_is_the_published_sidereal_period(name, period_d):
    # JPL's table gives P = 0.3189 d and 1.2624 d; the mean motion must reproduce them
    assert MOONS[name].period_s / 86400.0 == pytest.approx(period_d, abs=1e-4)


@pytest.mark.parametrize("name", ["phobos", "deimos"])
def test_velocity_is_the_instant_ellipse_and_close_to_the_motion(name):
    t = 5.96e8 + np.linspace(0.0, 86400.0, 9)
    p, v = moon_state(name, t)
    h = 1.0
    fd = (moon_state(name, t + h)[0] - moon_state(name, t - h)[0]) / (2 * h)
    el = MOONS[name]
    # the precession rates the velocity leaves out: a (dw/dt + dnode/dt) at most
    rates = 2 * math.pi * (1 / el.p_argp_yr + 1 / el.p_node_yr) / (365.25 * 86400.0)
    assert np.max(np.linalg.norm(fd - v, axis=1)) < 1.1 * el.a_km * rates + 1e-7


@pytest.mark.parametrize("name", ["phobos", "deimos"])
def test_orbit_plane_is_inclined_to_its_laplace_plane_and_precesses(name):
    el = MOONS[name]
    pole = radec_to_unit(math.radians(el.laplace_ra_deg), math.radians(el.laplace_dec_deg))
    for t in (5.9e8, 5.9e8 + 0.25 * el.p_node_yr * 365.25 * 86400.0):
        p, v = moon_state(name, t + np.linspace(0.0, 600.0, 3))
        h = np.cross(p, v)
        i = np.degrees(np.arccos(h @ pole / np.linalg.norm(h, axis=1)))
        assert np.allclose(i, el.i_deg, atol=1e-6)
    # a quarter of the node period later the orbit normal has turned by ~ sqrt(2) sin i about the pole
    p0, v0 = moon_state(name, 5.9e8)
    p1, v1 = moon_state(name, 5.9e8 + 0.25 * el.p_node_yr * 365.25 * 86400.0)
    n0 = np.cross(p0, v0) / np.linalg.norm(np.cross(p0, v0))
    n1 = np.cross(p1, v1) / np.linalg.norm(np.cross(p1, v1))
    turn = math.degrees(math.acos(np.clip(n0 @ n1, -1, 1)))
    assert turn == pytest.approx(math.degrees(math.sqrt(2) * math.sin(math.radians(el.i_deg))), rel=2e-3)
    assert np.all(np.abs(np.linalg.norm(p0) / el.a_km - 1) < 0.016)


def test_unknown_moon():
    with pytest.raises(MoonError):
        moon_state("titan", 0.0)
    with pytest.raises(MoonError):
        moon_state("phobos", float("nan"))


@pytest.mark.parametrize("name", ["phobos", "deimos"])
def test_one_epoch_on_floats_is_the_array_form_to_the_bit(name):
    """An epoch given as a float takes the Python-float path; it must give what the numpy form
    gives for the same epoch as a 0-d array (what the onboard code computed before), to the bit,
    and agree with the vectorised (N,) form to rounding."""
    rng = np.random.default_rng(11)
    ts = np.concatenate([rng.uniform(5.0e8, 9.0e8, 3000), rng.uniform(-3e9, 3e9, 500)])
    for t in ts:
        p, v = moon_state(name, float(t))
        p0, v0 = moon_state(name, np.asarray(t))
        assert np.array_equal(p, p0) and np.array_equal(v, v0), t
    P, V = moon_state(name, ts)
    scalar = np.array([np.concatenate(moon_state(name, float(t))) for t in ts])
    assert np.allclose(scalar[:, :3], P, rtol=0, atol=1e-9 * MOONS[name].a_km)
    assert np.allclose(scalar[:, 3:], V, rtol=0, atol=1e-12)
    with pytest.raises(MoonError):
        moon_state(name, float("inf"))

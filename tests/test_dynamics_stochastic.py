"""Stochastic force draws: reproducibility and the statistics of Chaer et al. 1998 eqs. 25-26 / Lubey & Ely 2022."""

import math

import numpy as np
import pytest

from sim.dynamics.config import ForceModelConfig, ManeuverConfig, thruster_mismodel_truth, thruster_scale_truth
from sim.dynamics.stochastic import StochasticRealisation

T0 = 5.9e8
DAY = 86400.0


def test_same_seed_same_draw_different_seed_different_draw():
    f = ForceModelConfig(maneuvers=(ManeuverConfig(epoch_offset_days=10.0, dv_km_s=(1e-3, 0, 0), dv_sigma_rel=0.05),))
    a = StochasticRealisation.draw(f, T0, T0 + 45 * DAY, np.random.default_rng(7))
    b = StochasticRealisation.draw(f, T0, T0 + 45 * DAY, np.random.default_rng(7))
    c = StochasticRealisation.draw(f, T0, T0 + 45 * DAY, np.random.default_rng(8))
    assert np.array_equal(a.srp_scale, b.srp_scale) and np.array_equal(a.acs_magnitudes, b.acs_magnitudes)
    assert np.array_equal(a.maneuvers[0].dv_km_s, b.maneuvers[0].dv_km_s)
    assert not np.allclose(a.srp_scale, c.srp_scale)
    assert np.max(np.abs(a.acs_magnitudes - c.acs_magnitudes)) > 1e-14  # (allclose would see 1e-12 as 0)
    assert not np.allclose(a.acs_directions_body, c.acs_directions_body)


def test_srp_gauss_markov_statistics():
    # Many independent 45-day draws: stationary sigma and lag-1 correlation exp(-1/7).
    f = ForceModelConfig(srp_bias_sigma=0.0)
    rng = np.random.default_rng(11)
    g = np.array([StochasticRealisation.draw(f, T0, T0 + 45 * DAY, rng).srp_scale - 1.0 for _ in range(1500)])
    assert g.shape == (1500, 45)
    assert np.std(g[:, 0]) == pytest.approx(0.03, rel=0.08)
    assert np.std(g[:, 44]) == pytest.approx(0.03, rel=0.08)
    rho = np.mean(g[:, 1:] * g[:, :-1]) / np.mean(g * g)
    assert rho == pytest.approx(math.exp(-1 / 7), abs=0.02)
    # A constant bias shifts a whole run.
    fb = ForceModelConfig(srp_gm_sigma=0.0)
    s = np.array([StochasticRealisation.draw(fb, T0, T0 + 5 * DAY, rng).srp_scale for _ in range(1500)])
    assert np.allclose(s, s[:, :1])
    assert np.std(s[:, 0]) == pytest.approx(0.11, rel=0.08)


def test_acs_section_4_4_statistics():
    nominal = 5e-12
    f = thruster_mismodel_truth(ForceModelConfig(acs_directions_body=((1, 0, 0), (0, 1, 0), (0, 0, 1))))
    rng = np.random.default_rng(5)
    draws = [StochasticRealisation.draw(f, T0, T0 + 45 * DAY, rng).acs_magnitudes for _ in range(400)]
    m = np.array(draws)  # (runs, thrusters, days)
    run_mean = m.mean(axis=2)  # the bias plus averaged daily noise (10/sqrt(45) x nominal)
    assert np.std(run_mean) / nominal == pytest.approx(math.sqrt(9 + 100 / 45), rel=0.1)
    daily = m - m.mean(axis=2, keepdims=True)
    assert np.std(daily) / nominal == pytest.approx(10.0 * math.sqrt(44 / 45), rel=0.05)
    scaled = StochasticRealisation.nominal(thruster_scale_truth(ForceModelConfig()), T0, T0 + DAY)
    assert scaled.acs_magnitudes[0, 0] == pytest.approx(10 * nominal)


def test_pointing_error_size():
    f = ForceModelConfig(acs_bias_sigma_rel=0.0, acs_daily_sigma_rel=0.0)
    rng = np.random.default_rng(2)
    d0 = np.array(f.acs_directions_body[0]) / np.linalg.norm(f.acs_directions_body[0])
    ang = [math.degrees(math.acos(min(1.0, StochasticRealisation.draw(f, T0, T0 + DAY, rng).acs_directions_body[0] @ d0)))
           for _ in range(2000)]
    # Two transverse N(0, 3 deg) axes: the total angle is Rayleigh with RMS 3 sqrt(2) deg.
    assert math.sqrt(np.mean(np.square(ang))) == pytest.approx(3 * math.sqrt(2), rel=0.05)


def test_batches_and_discontinuities():
    f = ForceModelConfig(srp_batch_days=2.0, maneuvers=(ManeuverConfig(epoch_offset_days=3.25, dv_km_s=(0, 0, 1e-4)),))
    r = StochasticRealisation.draw(f, T0, T0 + 5.5 * DAY, np.random.default_rng(0))
    assert r.srp_edges.tolist() == [T0, T0 + 2 * DAY, T0 + 4 * DAY, T0 + 5.5 * DAY]
    assert r.srp_scale_at(T0 + 2 * DAY) == r.srp_scale[1]
    assert np.allclose(r.discontinuities() - T0, np.array([1, 2, 3, 3.25, 4, 5]) * DAY)
    assert r.acs_body_vector_at(np.array([T0, T0 + DAY])).shape == (2, 3)

"""The truth's non-gravitational acceleration (Chaer et al. 1998 eqs. 25-26) and the nga-level fault."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sim.config import SimConfig
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.dynamics.forces import make_rhs
from sim.dynamics.propagator import make_table, propagate
from sim.dynamics.stochastic import DynamicsError, StochasticRealisation
from sim.faults.apply import fault_windows, nga_level
from sim.faults.config import FaultConfig

T0 = 5.9e8
H = 3600.0
SIGMA = 0.7e-12


def _nga(n_batches: int, tau_days: float, seed: int = 3, sigma: float = SIGMA) -> StochasticRealisation:
    f = ForceModelConfig(nga_sigma_km_s2=sigma, nga_tau_days=tau_days, nga_batch_s=H)
    return StochasticRealisation.draw(f, T0, T0 + n_batches * H, np.random.default_rng(1), np.random.default_rng(seed))


def test_ecrv_variance_and_lag_one_correlation_follow_eq_26():
    # tau = 2 batches: m = exp(-1/2); 60,000 batches x 3 axes give ~1 % statistics
    r = _nga(60_000, tau_days=2 * H / 86400.0)
    x = r.nga_accel
    assert x.shape == (60_000, 3)
    assert np.std(x) == pytest.approx(SIGMA, rel=0.03)
    rho = np.sum(x[1:] * x[:-1]) / np.sum(x[:-1] * x[:-1])
    assert rho == pytest.approx(math.exp(-0.5), abs=0.015)
    axes = np.corrcoef(x.T)
    assert np.max(np.abs(axes - np.eye(3))) < 0.05  # independent axes
    # the Chaer et al. 1998 time constant: 7 days of 1-hour batches, m = exp(-1/168)
    r7 = _nga(200_000, tau_days=7.0)
    y = r7.nga_accel
    assert np.sum(y[1:] * y[:-1]) / np.sum(y[:-1] ** 2) == pytest.approx(math.exp(-1 / 168), abs=2e-3)
    assert np.std(y) == pytest.approx(SIGMA, rel=0.1)


def test_recursion_by_hand_and_level_change():
    r = _nga(6, tau_days=1.0)
    m = math.exp(-H / 86400.0)
    w = r.nga_normals
    x = SIGMA * w[0]
    for k in range(1, 6):
        x = m * x + SIGMA * math.sqrt(1 - m * m) * w[k]
        np.testing.assert_allclose(r.nga_accel[k], x, rtol=1e-12)
    # level change at the start of batch 3: same normals, q from the new sigma (eq. 26)
    fault = FaultConfig(type="nga-level", onset_day=3 * H / 86400.0, sigma_km_s2=10 * SIGMA)
    changed = nga_level(r, SIGMA, fault_windows((fault,), T0))
    np.testing.assert_array_equal(changed.nga_accel[:3], r.nga_accel[:3])
    x = changed.nga_accel[2]
    for k in range(3, 6):
        x = m * x + 10 * SIGMA * math.sqrt(1 - m * m) * w[k]
        np.testing.assert_allclose(changed.nga_accel[k], x, rtol=1e-12)
    # in the long run the variance relaxes to the new level
    long = _nga(40_000, tau_days=2 * H / 86400.0)
    f2 = FaultConfig(type="nga-level", onset_day=10_000 * H / 86400.0, sigma_km_s2=10 * SIGMA)
    big = nga_level(long, SIGMA, fault_windows((f2,), T0)).nga_accel
    assert np.std(big[:10_000]) == pytest.approx(SIGMA, rel=0.05)
    assert np.std(big[10_100:]) == pytest.approx(10 * SIGMA, rel=0.05)


def test_nga_has_its_own_stream_and_is_off_by_default():
    f = ForceModelConfig()
    on = dataclasses.replace(f, nga_sigma_km_s2=SIGMA)
    a = StochasticRealisation.draw(f, T0, T0 + 5 * 86400.0, np.random.default_rng(4))
    b = StochasticRealisation.draw(on, T0, T0 + 5 * 86400.0, np.random.default_rng(4), np.random.default_rng(9))
    assert np.array_equal(a.srp_scale, b.srp_scale) and np.array_equal(a.acs_magnitudes, b.acs_magnitudes)
    assert a.nga_edges is None and b.nga_edges.size == 5 * 24 + 1
    assert np.array_equal(a.discontinuities(), np.unique(a.discontinuities()))
    assert on.without_dispersions().nga_sigma_km_s2 == 0.0
    with pytest.raises(DynamicsError):
        StochasticRealisation.draw(on, T0, T0 + 86400.0, np.random.default_rng(4))


def test_rhs_adds_the_inertial_nga_and_the_arc_responds_like_half_a_t_squared():
    f = ForceModelConfig(include_sun=False, include_earth=False, include_jupiter=False, srp_enabled=False,
                         acs_nominal_km_s2=0.0).without_dispersions()
    table = make_table(T0, T0 + 86400.0)
    y = np.array([5e6, 1e6, -2e6, 0.1, 0.5, 0.2])
    a = np.array([1e-11, -2e-11, 3e-11])
    d = make_rhs(f, table, 1.0, np.zeros(3), a)(T0, y) - make_rhs(f, table, 1.0, np.zeros(3))(T0, y)
    np.testing.assert_allclose(d[3:], a, rtol=1e-3, atol=1e-24)
    assert np.all(d[:3] == 0.0)
    # one constant batch over 1 h, far from Mars: the extra displacement is a T^2 / 2
    fn = dataclasses.replace(f, nga_sigma_km_s2=1e-9, nga_batch_s=2 * H)
    real = StochasticRealisation.draw(fn, T0, T0 + H, np.random.default_rng(0), np.random.default_rng(2))
    with_nga = propagate(y, T0, T0 + H, fn, real, table)
    without = propagate(y, T0, T0 + H, f, StochasticRealisation.nominal(f, T0, T0 + H), table)
    shift = with_nga.final_state[:3] - without.final_state[:3]
    np.testing.assert_allclose(shift, 0.5 * real.nga_accel[0] * H * H, rtol=1e-4)
    np.testing.assert_allclose(with_nga.nga_accel(T0 + 10.0), real.nga_accel[0])


def test_nga_level_fault_config():
    with pytest.raises(ValueError, match="sigma_km_s2"):
        FaultConfig(type="nga-level", onset_day=1.0)
    with pytest.raises(ValueError):
        FaultConfig(type="nga-level", onset_day=1.0, sigma_km_s2=-1e-12)
    with pytest.raises(ValueError, match="does not take"):
        FaultConfig(type="nga-level", onset_day=1.0, sigma_km_s2=1e-12, scale=2.0)
    f = FaultConfig(type="nga-level", onset_day=1.0, sigma_km_s2=7e-12)
    assert f.fault_class == "dynamics" and f.magnitude() == {"sigma_km_s2": 7e-12}
    with pytest.raises(ValueError, match="non-gravitational acceleration on"):
        SimConfig(faults=(f,))
    SimConfig(forces=ForceModelConfig(nga_sigma_km_s2=SIGMA), faults=(f,))
    TrajectoryConfig(kind="pathfinder-cruise")

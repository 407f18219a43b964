"""The FSW side of Chaer et al.'s (1998) NGA: the batched acceleration as an ECRV (eqs. 25-26), and cruise
filters with no ACS, clock or range-bias states."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fsw.filters.bank import FilterBank
from fsw.filters.config import (AcsConfig, BankConfig, BatchedParameterConfig, ClockConfig, FilterConfig,
                                PolyAccelConfig, SrpConfig)
from fsw.filters.kalman import is_spd
from fsw.models.environment import Environment
from tools.bench.synthetic import make_run

ENV = Environment()
TAU = 7 * 86400.0
S = 7e-12


def _cruise_filter(name: str, sigma: float, tau: float | None, scale: float = 1.0) -> FilterConfig:
    return FilterConfig(
        name=name, processes=("doppler",),
        srp=SrpConfig(scale=BatchedParameterConfig(0.11, 0.0, 86400.0, None)),
        acs=AcsConfig(nominal_km_s2=0.0, magnitude=BatchedParameterConfig(0.0, 0.0, 86400.0, None), direction_sigma_deg=0.0),
        clock=ClockConfig(phase_sigma_s=0.0), range_bias_sigma_km=0.0,
        accel=PolyAccelConfig(sigma_km_s2=sigma, degree=0, batch_length_s=3600.0, correlation_time_s=tau),
        sigma_scale={"doppler": scale},
    )


@pytest.fixture(scope="module")
def run():
    return make_run(span_days=1.0, max_measurements=200, optical=False, env=ENV)


def _bank(run) -> FilterBank:
    cfg = BankConfig(filters=(_cruise_filter("ecrv", S, TAU), _cruise_filter("white", S, None),
                              _cruise_filter("noisy", 0.7e-12, 86400.0, scale=10.0)))
    return FilterBank(cfg, run.t0, run.position_km + 10.0, run.velocity_km_s, env=ENV)


def test_batch_edge_step_is_chaer1998_eq_25_26(run):
    bank = _bank(run)
    L = bank.stack.layout
    assert bank.state_names == ("rx", "ry", "rz", "vx", "vy", "vz", "srp_bias", "srp_stoch",
                                "accel_x0", "accel_y0", "accel_z0")
    assert not bank.stack.present[:, L.index("srp_stoch")].any()  # no SRP Gauss-Markov part
    a = L.slices["accel"]
    assert a.stop - a.start == 3  # degree 0: one coefficient per axis
    o = bank.stack.batch_origin
    edge = o + 3 * 3600.0
    bank.propagate_to(edge - 1.0)
    x = bank.stack.x
    x[:, a] = np.array([2e-12, -1e-12, 3e-12])
    P_before = bank.stack.P[:, a, a].copy()
    bank.propagate_to(edge)  # the edge is applied on arrival
    m = math.exp(-3600.0 / TAU)
    # hand computation: x <- m x, P <- m^2 P + S^2 (1 - m^2), cross terms <- m (one more second of flow)
    np.testing.assert_allclose(bank.stack.x[0, a], m * np.array([2e-12, -1e-12, 3e-12]), rtol=1e-12)
    np.testing.assert_allclose(bank.stack.P[0, a, a], m * m * P_before[0] + S * S * (1 - m * m) * np.eye(3), rtol=1e-9)
    # the uncorrelated filter is re-initialised: x <- 0, P <- S^2 I, no cross-covariance
    np.testing.assert_array_equal(bank.stack.x[1, a], 0.0)
    np.testing.assert_allclose(bank.stack.P[1, a, a], S * S * np.eye(3), rtol=1e-12)
    assert np.all(bank.stack.P[1, a, 0:6] == 0.0)
    m3 = math.exp(-3600.0 / 86400.0)
    np.testing.assert_allclose(bank.stack.P[2, a, a], m3 * m3 * P_before[2] + 0.49e-24 * (1 - m3 * m3) * np.eye(3),
                               rtol=1e-9)


def test_cruise_filters_process_doppler_without_acs_clock_or_range_bias(run):
    bank = _bank(run)
    names = bank.state_names
    assert not any(n.startswith(("acs", "clock", "range_bias")) for n in names)
    n = 0
    for meas in run.measurements:
        if meas.kind != "doppler":
            continue
        rec = bank.process(meas)
        assert rec.processed.all() and np.all(np.isfinite(rec.chi2))
        # S = H P H' + R with the filter's own sigma scale
        assert rec.S[2, 0, 0] > 99.0 * meas.sigma[0] ** 2
        n += 1
    assert n > 50
    for i in range(3):
        assert is_spd(bank.stack.P[i])

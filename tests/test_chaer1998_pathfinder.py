"""Chaer et al. 1998 §V end to end: the pathfinder-cruise scenario flown in process, the hierarchical gates'
selections before and after the mid-cruise change of the non-gravitational acceleration level."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.astro.constants import SECONDS_PER_DAY
from tools.scenario import load_scenario

# Chaer et al. 1998 Table I: (bank, filter) -> (tau [days], sigma_nga [1e-12 km/s^2], sigma_n [mm/s])
TABLE_I = {
    (1, 1): (1.0, 0.07, 0.01), (1, 2): (7.0, 0.07, 0.01), (1, 3): (30.0, 0.07, 0.01),
    (2, 1): (1.0, 0.7, 0.01), (2, 2): (7.0, 0.7, 0.01), (2, 3): (30.0, 0.7, 0.01),
    (3, 1): (1.0, 7.0, 0.01), (3, 2): (7.0, 7.0, 0.01), (3, 3): (30.0, 7.0, 0.01),
    (4, 1): (7.0, 0.7, 0.001), (4, 2): (7.0, 0.7, 0.05), (4, 3): (7.0, 0.7, 0.10),
}


def test_scenario_is_table_i():
    cfg = load_scenario("pathfinder-cruise")
    filters = {f.name: f for f in cfg.fsw.bank.filters}
    assert len(filters) == 12
    for (i, j), (tau, sig, sig_n) in TABLE_I.items():
        f = filters[f"kf{j}_{i}"]
        assert f.processes == ("doppler",)
        assert f.accel.degree == 0 and f.accel.batch_length_s == 3600.0
        assert f.accel.correlation_time_s == pytest.approx(tau * SECONDS_PER_DAY)
        assert f.accel.sigma_km_s2 == pytest.approx(sig * 1e-12)
        assert f.sigma_scale["doppler"] * cfg.sim.radiometric.doppler_sigma_mm_s == pytest.approx(sig_n)
    (gate,) = [g for g in cfg.fsw.gating if g.network == "hierarchical"]
    assert gate.params.eta_top == gate.params.eta_bank == 1.0
    assert {b: tuple(m) for b, m in gate.params.groups.items()} == {
        f"bank{i}": tuple(f"kf{j}_{i}" for j in (1, 2, 3)) for i in (1, 2, 3, 4)}
    sim = cfg.sim
    assert sim.forces.nga_sigma_km_s2 == 0.7e-12 and sim.forces.nga_tau_days == 7.0
    (fault,) = sim.faults
    assert fault.type == "nga-level" and fault.sigma_km_s2 == 7.0e-12
    assert fault.onset_day == pytest.approx(sim.trajectory.span_days / 2)
    assert [(p.station, p.first_day, p.period_days, p.duration_h) for p in sim.radiometric.pass_plan] == [
        ("DSS-15", 7.0, 7.0, 4.0), ("DSS-45", 10.0, 7.0, 4.0), ("DSS-65", 12.0, 7.0, 4.0)]
    assert not sim.optical.enabled and not sim.radiometric.range_enabled


@pytest.mark.slow
def test_top_level_gate_moves_from_bank_2_to_bank_3():
    from tools.inprocess import run_in_process
    from tools.validation.chaer1998 import analyse

    cfg = load_scenario("pathfinder-cruise")
    res = run_in_process(cfg, keep_sim=True)
    n = len(res.sim.measurements)
    assert 1100 <= n <= 1350  # Chaer et al. 1998: 1,230 observations
    r = analyse(res)
    assert r.t_day.size == n
    np.testing.assert_allclose(r.top.sum(axis=1), 1.0, rtol=1e-9)
    # second quarter (before the change) and last quarter (after it)
    assert max(r.top_mean_before, key=r.top_mean_before.get) == "bank2", r.top_mean_before
    assert max(r.top_mean_after, key=r.top_mean_after.get) == "bank3", r.top_mean_after
    assert r.top_mean_before["bank2"] > 0.9 and r.top_mean_after["bank3"] > 0.9
    # bank 3 takes over for good within two weeks of the change
    assert r.overtake_day is not None and r.change_day < r.overtake_day < r.change_day + 14
    # in-bank, after the change: bank 2 moves to the short time constant (KF 1|2), bank 3 picks KF 2|3
    assert max(r.in_bank_after["bank2"], key=r.in_bank_after["bank2"].get) == "kf1_2"
    assert max(r.in_bank_after["bank3"], key=r.in_bank_after["bank3"].get) == "kf2_3"

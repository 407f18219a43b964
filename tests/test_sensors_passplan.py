"""The periodic pass plan of Chaer et al.'s (1998) Pathfinder cruise: stations, days, length, cadence."""

from __future__ import annotations

import numpy as np
import pytest

from sim.truth.stations import station
from sim.clock import ClockConfig
from sim.config import SimConfig
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.sensors.config import OpticalConfig, PassPlan, RadiometricConfig
from sim.sensors.geometry import Scene
from sim.sensors.radiometric import make_schedule, plan_passes, uplink
from sim.stream import generate

PLAN = (PassPlan("DSS-15", 7.0), PassPlan("DSS-45", 10.0), PassPlan("DSS-65", 12.0))


@pytest.fixture(scope="module")
def run():
    cfg = SimConfig(
        trajectory=TrajectoryConfig(kind="pathfinder-cruise", span_days=30.0),
        forces=ForceModelConfig(acs_nominal_km_s2=0.0, acs_bias_sigma_rel=0.0, acs_daily_sigma_rel=0.0,
                                acs_direction_sigma_deg=0.0),
        clock=ClockConfig(q_white_fm_s=0.0, q_random_walk_fm_per_s=0.0, q_random_run_per_s3=0.0, phase0_sigma_s=0.0,
                          frequency0_sigma=0.0, drift_per_day=0.0, drift_sigma_per_day=0.0),
        radiometric=RadiometricConfig(stations=("DSS-15", "DSS-45", "DSS-65"), range_enabled=False,
                                      doppler_interval_s=600.0, doppler_count_s=600.0, doppler_sigma_mm_s=0.01,
                                      pass_plan=PLAN),
        optical=OpticalConfig(enabled=False),
    )
    return generate(cfg, seed=2)


def test_pass_plan_days_stations_length_and_cadence(run):
    assert run.counts() == {"doppler": len(run.measurements)}
    t = run.t_true
    st = run.radio.station
    expected = {"DSS-15": [7, 14, 21, 28], "DSS-45": [10, 17, 24], "DSS-65": [12, 19, 26]}
    for name, days in expected.items():
        ts = t[st == name]
        # passes: runs of points 10 min apart; a new pass after a gap
        breaks = np.flatnonzero(np.diff(ts) > 601.0)
        starts = np.concatenate([[0], breaks + 1])
        ends = np.concatenate([breaks, [ts.size - 1]])
        assert len(starts) == len(days)
        for a, b, d in zip(starts, ends, days):
            assert b - a + 1 == 24  # 4 h of 10-min counts, all above the mask
            np.testing.assert_allclose(np.diff(ts[a:b + 1]), 600.0)
            centre = 0.5 * (ts[a] - 600.0 + ts[b])  # the pass spans [first count start, last tag]
            assert d - 0.2 <= (centre - run.t_start) / 86400.0 <= d + 1.2
    assert len(run.measurements) == 24 * 10
    assert np.all(run.radio.sigma == pytest.approx(1e-8))
    assert {m.count_time_s for m in run.measurements} == {600.0}
    assert np.degrees(run.radio.elevation_rad).min() >= 10.0


def test_passes_are_centred_on_the_transit(run):
    cfg = run.config.radiometric
    scene = Scene(run.trajectory.position, run.t_start, run.t_end)
    ps, pe, names = plan_passes(cfg, scene, run.t_start, run.t_end)
    assert list(names[:3]) == ["DSS-15", "DSS-45", "DSS-65"]
    np.testing.assert_allclose(pe - ps, 4 * 3600.0)
    for a, b, n in zip(ps, pe, names):
        grid = np.linspace(a - 6 * 3600.0, b + 6 * 3600.0, 97)
        el = uplink(scene, n, grid)[1]
        assert abs(grid[np.argmax(el)] - 0.5 * (a + b)) <= 900.0
    sched = make_schedule(cfg, run.t_start, run.t_end, (ps, pe))
    assert sched.doppler_t.size == 24 * ps.size and sched.range_t.size == 0


def test_pass_plan_rejects_unknown_stations():
    with pytest.raises(ValueError):
        RadiometricConfig(pass_plan=(PassPlan("DSS-99", 1.0),))
    assert station("dss45").name == "DSS-45"

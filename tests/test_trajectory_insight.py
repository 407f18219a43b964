"""The built-in insight-approach trajectory: closure on the entry state, InSight-like geometry,
reproducibility, timing, and the approach plot."""

import math
import time

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fsw.astro.constants import AU_KM, GM_SUN, R_MARS_EQ_KM
from fsw.astro.ephemeris import default_ephemeris
from sim.truth.mars import body_fixed_to_icrf_matrix
from sim.truth.timescales import utc_iso_to_tdb
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.trajectories.insight import (
    build_truth_trajectory,
    entry_state,
    hyperbolic_excess_speed,
    insight_initial_state,
    plot_approach,
)

CFG = TrajectoryConfig()
FORCES = ForceModelConfig()


def test_entry_state_matches_its_definition():
    t_e, x = entry_state(CFG)
    assert t_e == pytest.approx(utc_iso_to_tdb("2018-11-26T19:47:00"))
    r, v = x[:3], x[3:]
    assert np.linalg.norm(r) == pytest.approx(3522.2, abs=1e-9)
    assert np.linalg.norm(r) - R_MARS_EQ_KM == pytest.approx(126.0, abs=0.1)
    assert np.linalg.norm(v) == pytest.approx(5.75, abs=1e-12)
    fpa = math.degrees(math.asin(np.dot(r, v) / (np.linalg.norm(r) * np.linalg.norm(v))))
    assert fpa == pytest.approx(-12.0, abs=1e-9)
    rb = body_fixed_to_icrf_matrix(t_e).T @ r
    assert math.degrees(math.atan2(rb[1], rb[0])) == pytest.approx(124.0, abs=1e-9)
    assert math.degrees(math.asin(rb[2] / np.linalg.norm(rb))) == pytest.approx(0.0, abs=1e-9)
    assert hyperbolic_excess_speed(x) == pytest.approx(2.96, abs=0.05)


def test_forward_run_without_dispersions_reaches_entry():
    t_e, x_e = entry_state(CFG)
    start = time.perf_counter()
    traj = build_truth_trajectory(CFG, FORCES.without_dispersions(), None)
    elapsed = time.perf_counter() - start
    print(f"45-day truth build (no dispersions): {elapsed:.2f} s, {traj.nfev} evaluations, {traj.n_segments} segments")
    assert traj.t1 == pytest.approx(t_e, abs=1e-6)
    assert np.linalg.norm(traj.state(t_e)[:3] - x_e[:3]) < 1.0  # km
    assert np.linalg.norm(traj.state(t_e)[3:] - x_e[3:]) < 1e-3  # km/s
    assert elapsed < 20.0


def test_initial_state_is_insight_like():
    t0, x0 = insight_initial_state(CFG, FORCES)
    t_e, _ = entry_state(CFG)
    assert t_e - t0 == pytest.approx(45 * 86400.0)
    assert 5e6 < np.linalg.norm(x0[:3]) < 2e7  # v_inf ~ 3 km/s for 45 days: ~1.1e7 km
    assert 2.5 < hyperbolic_excess_speed(x0) < 3.5
    # Heliocentric osculating orbit of the initial state: a Type-I Earth-Mars transfer ...
    eph = default_ephemeris()
    ps, vs = eph.state("sun", t0, "mars")
    r, v = x0[:3] - ps, x0[3:] - vs
    energy = np.dot(v, v) / 2 - GM_SUN / np.linalg.norm(r)
    a = -GM_SUN / (2 * energy)
    e = np.linalg.norm(np.cross(v, np.cross(r, v)) / GM_SUN - r / np.linalg.norm(r))
    assert 0.95 < a * (1 - e) / AU_KM < 1.05
    # ... that, flown back on a conic, passes near Earth on InSight's launch day.
    t_l = utc_iso_to_tdb("2018-05-05T11:05:00")
    sol = solve_ivp(lambda t, y: np.concatenate([y[3:], -GM_SUN * y[:3] / np.linalg.norm(y[:3]) ** 3]),
                    (t0, t_l), np.concatenate([r, v]), rtol=1e-10, atol=1e-3)
    pe, ve = eph.state("earth", t_l, "sun")
    assert np.linalg.norm(sol.y[:3, -1] - pe) / AU_KM < 0.01
    assert np.linalg.norm(sol.y[3:, -1] - ve) == pytest.approx(2.86, abs=0.3)  # InSight C3 8.2 km^2/s^2


def test_truth_is_reproducible_and_seed_dependent():
    a = build_truth_trajectory(CFG, FORCES, np.random.default_rng(42))
    b = build_truth_trajectory(CFG, FORCES, np.random.default_rng(42))
    c = build_truth_trajectory(CFG, FORCES, np.random.default_rng(43))
    t = np.linspace(a.t0, a.t1, 20000)
    start = time.perf_counter()
    xa = a.state(t)
    print(f"state() for 20000 epochs: {1e3 * (time.perf_counter() - start):.1f} ms")
    assert np.array_equal(xa, b.state(t))
    assert np.array_equal(a.acs_accel(t[::100]), b.acs_accel(t[::100]))
    assert not np.array_equal(a.realisation.acs_magnitudes, c.realisation.acs_magnitudes)
    assert not np.array_equal(a.srp_scale(t[::100]), c.srp_scale(t[::100]))
    miss = np.linalg.norm(a.state(a.t1)[:3] - c.state(c.t1)[:3])
    assert 0.01 < miss < 1000.0  # dispersions move the entry point by km, not by Mars radii
    assert xa.shape == (20000, 6) and a.state(t[5]).shape == (6,)
    assert np.allclose(a.state(t[5]), xa[5], atol=1e-12, rtol=0)
    acs = np.linalg.norm(a.acs_accel(t[::500]), axis=1)
    assert np.all((acs > 3e-12) & (acs < 7e-12))


def test_plot_approach_writes_png(tmp_path):
    traj = build_truth_trajectory(CFG, FORCES.without_dispersions(), None)
    path = tmp_path / "approach.png"
    plot_approach(traj, str(path), n=300)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20000

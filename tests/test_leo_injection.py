"""The leo-injection pieces: ground-station measurement kinds and their exact partials, the onboard
two-body + J2 model, the truth zonals and drag against independent checks, the scenario's
measurements and the Earth-orbit bank (Garhwal, Halder & Sinha)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from fsw.astro.constants import GM_EARTH, R_EARTH_EQ_KM
from fsw.interface import kinds
from fsw.models import earth_gravity, topocentric
from sim.dynamics import earth_orbit
from sim.dynamics.earth_orbit import EarthForceConfig


APRIORI_SIGMA = np.array([10.0] * 3 + [0.02] * 3)


def _geometry(seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    r_s = rng.normal(0.0, 1.0, 3)
    r_s *= 6378.0 / np.linalg.norm(r_s)
    up = r_s / np.linalg.norm(r_s)
    east = np.cross([0.0, 0.0, 1.0], up)
    east /= np.linalg.norm(east)
    enu = np.vstack([east, np.cross(up, east), up])[None]
    r = r_s + 800.0 * (up + rng.uniform(-0.8, 0.8) * east + rng.uniform(-0.8, 0.8) * enu[0, 1])
    v = rng.normal(0.0, 5.0, 3)
    v_s = np.cross([0.0, 0.0, 7.292e-5], r_s)
    return r[None], v[None], r_s[None], v_s[None], enu


@pytest.mark.parametrize("seed", range(8))
def test_topocentric_partials_match_central_differences(seed: int) -> None:
    r, v, r_s, v_s, enu = _geometry(seed)
    h, H = topocentric.predict(r, v, r_s, v_s, enu)
    z = np.concatenate([r[0], v[0]])
    num = np.empty((4, 6))
    for j in range(6):
        step = 1e-4 if j < 3 else 1e-7
        dz = np.zeros(6)
        dz[j] = step
        hp, _ = topocentric.predict((z + dz)[None, 0:3], (z + dz)[None, 3:6], r_s, v_s, enu)
        hm, _ = topocentric.predict((z - dz)[None, 0:3], (z - dz)[None, 3:6], r_s, v_s, enu)
        num[:, j] = topocentric.wrap_residual(hp[0] - hm[0], topocentric.COMPONENTS) / (2 * step)
    assert H[0] == pytest.approx(num, rel=1e-6, abs=1e-10)
    assert 0.0 < h[0, 3] < math.pi / 2 and 0.0 <= h[0, 2] < 2 * math.pi


def test_topocentric_values_are_the_geometry() -> None:
    r_s = np.array([[6378.0, 0.0, 0.0]])
    enu = np.array([[[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]])  # east +y, north +z, up +x
    r = np.array([[6378.0 + 500.0, 0.0, 500.0]])  # 45° elevation due north
    v = np.array([[0.0, 1.0, 0.0]])
    h, _ = topocentric.predict(r, v, r_s, np.zeros((1, 3)), enu)
    assert h[0] == pytest.approx([500.0 * math.sqrt(2), 0.0, 0.0, math.pi / 4])
    assert topocentric.wrap_residual(np.array([2 * math.pi - 0.1, 6.0]), ("azimuth", "station-range"))[0] \
        == pytest.approx(-0.1)


def test_kinds_are_declared_in_the_icd() -> None:
    for name in topocentric.COMPONENTS:
        assert kinds.declaration(name).dimension == 1


def _potential(r: np.ndarray, zonals: int) -> float:
    """U = μ/r [1 − Σ J_n (R/r)^n P_n(sin φ)]: the textbook zonal potential, an independent check
    of the accelerations (a = ∇U)."""
    rn = float(np.linalg.norm(r))
    u = r[2] / rn
    p = {2: 0.5 * (3 * u * u - 1), 3: 0.5 * (5 * u ** 3 - 3 * u), 4: (35 * u ** 4 - 30 * u * u + 3) / 8}
    j = {2: earth_orbit.J2, 3: earth_orbit.J3, 4: earth_orbit.J4}
    return GM_EARTH / rn * (1 - sum(j[n] * (R_EARTH_EQ_KM / rn) ** n * p[n] for n in range(2, zonals + 1)))


@pytest.mark.parametrize("zonals", [2, 3, 4])
def test_truth_zonal_acceleration_is_the_potential_gradient(zonals: int) -> None:
    rng = np.random.default_rng(zonals)
    for _ in range(5):
        r = rng.normal(0.0, 1.0, 3)
        r *= 7000.0 / np.linalg.norm(r)
        # the gradient of the zonal part alone (its differences stay clear of the point mass's rounding)
        grad = np.array([(_potential(r + d, zonals) - _potential(r - d, zonals) - _potential(r + d, 0)
                          + _potential(r - d, 0)) / 0.2 for d in 0.1 * np.eye(3)])
        zonal = earth_orbit.zonal_acceleration(r, zonals) - earth_orbit.zonal_acceleration(r, 0)
        assert zonal == pytest.approx(grad, rel=1e-6, abs=1e-16)
    assert earth_gravity.acceleration(r) == pytest.approx(earth_orbit.zonal_acceleration(r, 2), rel=1e-12)


def test_onboard_gradient_and_stm_match_differences() -> None:
    from sim.scenarios.leo_injection import elements_to_state

    z = elements_to_state(6900.0, 0.01, math.radians(97.5), 0.3, 1.0, 0.5)
    r = z[0:3]
    G = earth_gravity.gradient(r)
    num = np.column_stack([(earth_gravity.acceleration(r + d) - earth_gravity.acceleration(r - d)) / 2e-2
                           for d in 1e-2 * np.eye(3)])
    assert G == pytest.approx(num, rel=1e-6, abs=1e-14)
    _, phi = earth_gravity.propagate(z[None], 30.0)
    num_phi = np.column_stack([(earth_gravity.propagate((z + d)[None], 30.0)[0][0]
                                - earth_gravity.propagate((z - d)[None], 30.0)[0][0]) / (2 * np.max(d))
                               for d in np.diag([1e-1] * 3 + [1e-4] * 3)])
    assert phi[0] == pytest.approx(num_phi, rel=1e-5, abs=1e-7)


def _elements(z: np.ndarray) -> tuple[float, float, float, float, float]:
    """(a, e, i, Ω, ω) of GCRS states (independent of the code under test)."""
    r, v = z[0:3], z[3:6]
    h = np.cross(r, v)
    n = np.cross([0.0, 0.0, 1.0], h)
    rn = np.linalg.norm(r)
    e_vec = np.cross(v, h) / GM_EARTH - r / rn
    a = 1.0 / (2.0 / rn - v @ v / GM_EARTH)
    raan = math.atan2(n[1], n[0])
    argp = math.atan2(np.cross(n, e_vec) @ h / np.linalg.norm(h), n @ e_vec)
    return a, float(np.linalg.norm(e_vec)), math.acos(h[2] / np.linalg.norm(h)), raan, argp


def test_truth_j2_secular_rates_over_a_day() -> None:
    """The numerically propagated J2-only truth drifts Ω and ω at the first-order secular rates
    Ω̇ = −(3/2) n J2 (R/p)² cos i, ω̇ = (3/4) n J2 (R/p)² (5 cos² i − 1) (Vallado eqs. 9-41, 9-42)."""
    from sim.scenarios.leo_injection import elements_to_state

    a0, e0, i0 = 6883.0, 0.02, math.radians(97.5)
    z0 = elements_to_state(a0, e0, i0, 1.0, 0.7, 0.0)
    t = np.arange(0.0, 86400.0 + 1.0, 30.0)
    cfg = EarthForceConfig(zonals=2, drag=False)
    Z = earth_orbit.propagate(z0, t, cfg)
    el = np.array([_elements(z) for z in Z])
    raan = np.unwrap(el[:, 3])
    argp = np.unwrap(el[:, 4])
    # the mean elements' a differs from the osculating a0 by O(J2); first order in J2 is what the
    # rates claim, so use the day's mean a, e, i
    a, e, i = el[:, 0].mean(), el[:, 1].mean(), el[:, 2].mean()
    n = math.sqrt(GM_EARTH / a ** 3)
    k = n * earth_orbit.J2 * (R_EARTH_EQ_KM / (a * (1 - e * e))) ** 2
    raan_rate = np.polyfit(t, raan, 1)[0]
    argp_rate = np.polyfit(t, argp, 1)[0]
    assert raan_rate == pytest.approx(-1.5 * k * math.cos(i), rel=0.01)
    assert argp_rate == pytest.approx(0.75 * k * (5 * math.cos(i) ** 2 - 1), rel=0.03)
    # sun-synchronous: the node turns ~0.9856°/day eastward at this a and i
    assert math.degrees(raan_rate) * 86400.0 == pytest.approx(0.9856, abs=0.05)


def test_truth_energy_is_conserved_without_drag_and_decays_with_it() -> None:
    from sim.scenarios.leo_injection import elements_to_state

    z0 = elements_to_state(6883.0, 0.001, math.radians(97.5), 0.0, 0.0, 0.0)
    t = np.arange(0.0, 6 * 3600.0, 60.0)
    conservative = EarthForceConfig(zonals=2, drag=False)
    e = earth_orbit.energy(earth_orbit.propagate(z0, t, conservative), conservative)
    assert np.ptp(e) < 1e-10 * abs(e[0])
    dragged = EarthForceConfig(zonals=2, drag=True)
    e_d = earth_orbit.energy(earth_orbit.propagate(z0, t, dragged), dragged)
    assert e_d[-1] < e_d[0]
    assert np.all(np.diff(e_d) <= 1e-12 * abs(e[0]))
    # ṁechanical energy loss rate = v·a_drag: at ~505 km, v ≈ 7.6 km/s and a ≈ 2e-10 km/s² → ~1e-9 km²/s³
    loss = (e_d[0] - e_d[-1]) / t[-1]
    assert 1e-10 < loss < 1e-8


def test_scenario_measurements_and_bank_converge() -> None:
    import itertools

    from fsw.filters.adaptive_q import AdaptiveQConfig
    from fsw.filters.orbit_bank import OrbitBank, OrbitFilterConfig
    from sim.scenarios.leo_injection import LeoInjectionConfig, generate

    cfg = LeoInjectionConfig(arc_s=120.0)
    run = generate(cfg, 5)
    assert run.measurements and all(m.kind in topocentric.COMPONENTS for m in run.measurements)
    assert [m.seq for m in run.measurements] == list(range(len(run.measurements)))
    assert generate(cfg, 5).measurements == run.measurements  # one seed, one realisation
    bank = OrbitBank([OrbitFilterConfig("ekf"), OrbitFilterConfig("lsq", AdaptiveQConfig(mode="lsq-adaptive"))],
                     run.t[0], run.apriori, APRIORI_SIGMA)
    err0 = np.linalg.norm(run.apriori[0:3] - run.truth[0, 0:3])
    k_of = {float(t): k for k, t in enumerate(run.t)}
    for tt, grp in itertools.groupby(run.measurements, key=lambda m: m.t_s):
        rec = bank.process_epoch(list(grp))
        assert np.all(np.isfinite(rec.chi2))
    k = k_of[bank.t]
    err = np.linalg.norm(bank.x[:, 0:3] - run.truth[k, 0:3], axis=1)
    assert np.all(err < 0.1) and err0 > 0.1
    aq = bank.adaptive[1]
    assert aq is not None and aq.active


def test_sequential_updates_match_the_joint_update_and_feed_one_residual_per_epoch() -> None:
    import itertools

    from fsw.filters.adaptive_q import AdaptiveQConfig
    from fsw.filters.errors import MeasurementRejected
    from fsw.filters.orbit_bank import OrbitBank, OrbitFilterConfig
    from sim.scenarios.leo_injection import LeoInjectionConfig, generate

    run = generate(LeoInjectionConfig(arc_s=30.0), 2)
    fl = [OrbitFilterConfig("ekf"), OrbitFilterConfig("lsq", AdaptiveQConfig(mode="lsq-adaptive", window=5, warmup=5))]
    joint = OrbitBank(fl, run.t[0], run.apriori, APRIORI_SIGMA)
    seq = OrbitBank(fl, run.t[0], run.apriori, APRIORI_SIGMA)
    epochs = 0
    for _, grp in itertools.groupby(run.measurements, key=lambda m: m.t_s):
        g = list(grp)
        joint.process_epoch(g)
        for m in g:
            rec = seq.process(m)
            assert rec.residual.shape == (2, 1) and rec.processed.all()
        epochs += 1
    # a linear update is the same jointly or one component at a time; the EKF relinearises
    # between components, which matters while the error is kilometres (the first epochs): the
    # two end well within their own uncertainty of each other
    sigma = np.sqrt(np.diagonal(joint.P, axis1=1, axis2=2))
    assert np.all(np.abs(seq.x - joint.x) < 0.5 * sigma)
    assert np.abs(seq.x - joint.x)[:, 0:3].max() < 2e-3
    assert np.sqrt(np.diagonal(seq.P, axis1=1, axis2=2)) == pytest.approx(
        np.sqrt(np.diagonal(joint.P, axis1=1, axis2=2)), rel=0.05)
    seq.propagate_to(seq.t + 1.0)  # leaving the epoch hands over its residual
    aq = seq.adaptive[1]
    assert aq is not None and aq._count == min(epochs, 5)
    bad = dataclasses.replace(run.measurements[0], source="goldstone", t_s=seq.t)
    before = seq.x.copy()
    with pytest.raises(MeasurementRejected):
        seq.process(bad)
    assert seq.rejected["unknown_source"] == 1 and np.array_equal(seq.x, before)


@pytest.mark.slow
def test_navbank_run_flies_the_leo_injection_scenario(tmp_path) -> None:
    """`navbank run --scenario leo-injection` over real Zenoh, a shortened arc: every measurement
    arrives, the three filters' estimates are recorded and end within a few hundred metres of truth."""
    import subprocess
    import sys

    from ground.mcap_io.reader import read_messages

    scen = tmp_path / "leo.yaml"
    text = (Path(__file__).parents[1] / "tools/scenarios/leo-injection.yaml").read_text()
    scen.write_text(text.replace("arc_s: 400.0", "arc_s: 120.0"))
    out = tmp_path / "o"
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "run", "--scenario", str(scen), "--out", str(out),
                           "--quiet"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    meas = [r.message for r in read_messages(out / "run.mcap", topics=["/sim/measurements"])]
    assert meas and {m.kind for m in meas} == set(topocentric.COMPONENTS)
    truth = {r.message.t_s: r.message for r in read_messages(out / "run.mcap", topics=["/sim/truth"])}
    for name in ("ekf", "lsq-adaptive", "fuzzy-adaptive"):
        est = [r.message for r in read_messages(out / "run.mcap", topics=["/fsw/estimate/" + name])]
        last = [e for e in est if e.t_s in truth][-1]
        err = np.linalg.norm(np.subtract(last.position_km, truth[last.t_s].position_km))
        assert err < 0.3, (name, err)
    status = [r.message for r in read_messages(out / "run.mcap", topics=["/fsw/status"])][-1]
    assert status.counts["processed"] == len(meas) and status.counts["adaptive_lp_solves"] > 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scenario"] == "leo-injection"


def test_tracking_kinds_are_registered_for_the_earth_orbit_bank_only() -> None:
    from fsw.filters import kinds as registry

    assert registry.ORBIT_KINDS == topocentric.COMPONENTS
    assert not set(registry.ORBIT_KINDS) & set(registry.FILTER_KINDS)
    for name, model in registry.ORBIT_REGISTRY.items():
        assert model.declaration is kinds.declaration(name)
        assert topocentric.COMPONENTS[model.component] == name
    assert [n for n, m in registry.ORBIT_REGISTRY.items() if m.wrap] == ["azimuth"]


@pytest.mark.parametrize("edit, message", [
    (("central_body: earth", "central_body: mars"), "go together"),
    (("central_body: earth", "central_body: earth\n  rqp: {enabled: true}"), "RQP"),
    (("sim:\n", "sim:\n  faults: [{type: optical-bias, onset_day: 0.001, sample_px: 1.0, line_px: 1.0}]\n"), "faults"),
])
def test_inconsistent_earth_orbit_scenarios_are_one_line_errors(edit: tuple[str, str], message: str) -> None:
    from fsw.interface.yamlconfig import ConfigError
    from tools.scenario import load_text_scenario

    text = (Path(__file__).parents[1] / "tools/scenarios/leo-injection.yaml").read_text()
    assert load_text_scenario(text).sim.leo is not None
    with pytest.raises(ConfigError, match=message) as err:
        load_text_scenario(text.replace(*edit, 1))
    assert "\n" not in str(err.value)


def test_a_fault_preset_is_refused_for_the_earth_orbit_case() -> None:
    from fsw.interface.yamlconfig import ConfigError
    from tools.scenario import load_scenario, with_fault

    with pytest.raises(ConfigError, match="--fault"):
        with_fault(load_scenario("leo-injection"), "optical-bias-medium")

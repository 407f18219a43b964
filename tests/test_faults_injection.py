"""Each preset changes exactly the intended measurements by the intended amount (same seed)."""

import numpy as np
import pytest

from fsw.astro.constants import C_KM_S, MHZ_TO_KM_S
from sim.faults.presets import FAULT_PRESETS, preset
from sim.stream import generate

SEED = 21
DAY = 86400.0


@pytest.fixture(scope="module")
def nominal():
    return generate(seed=SEED)


_CACHE: dict = {}


def faulted(name):
    if name not in _CACHE:
        _CACHE[name] = generate(faults=preset(name), seed=SEED)
    return _CACHE[name]


def _arrays(run):
    m = run.measurements
    kind = np.array([x.kind for x in m])
    tag = np.array([x.t_s for x in m])
    val = np.array([x.value + (np.nan,) * (2 - len(x.value)) for x in m])
    return kind, tag, val


def _compare(nom, bad):
    assert [(m.seq, m.kind, m.source) for m in nom.measurements] == [(m.seq, m.kind, m.source) for m in bad.measurements]
    np.testing.assert_array_equal(nom.t_true, bad.t_true)
    kn, tn, vn = _arrays(nom)
    _, tb, vb = _arrays(bad)
    return kn, tn, tb, vn, vb


@pytest.mark.parametrize("name,sample,line", [("optical-bias-small", 0.2, 0.3), ("optical-bias-medium", 2.0, 3.0),
                                               ("optical-bias-large", 20.0, 30.0)])
def test_optical_bias_moves_only_optical_centroids(nominal, name, sample, line):
    bad = faulted(name)
    kind, tn, tb, vn, vb = _compare(nominal, bad)
    t_on = nominal.t_start + 20 * DAY
    after = (nominal.t_true >= t_on) & (kind == "optical")
    np.testing.assert_array_equal(tn, tb)
    np.testing.assert_array_equal(vn[~after], vb[~after])
    np.testing.assert_allclose(vb[after] - vn[after], np.tile([sample, line], (after.sum(), 1)), atol=1e-9)
    assert after.sum() > 500


@pytest.mark.parametrize("name,r_m,d_mhz", [("radio-bias-small", 5.0, 0.03), ("radio-bias-medium", 50.0, 0.3),
                                             ("radio-bias-large", 500.0, 3.0)])
def test_radio_bias_moves_only_range_and_doppler(nominal, name, r_m, d_mhz):
    bad = faulted(name)
    kind, tn, tb, vn, vb = _compare(nominal, bad)
    late = nominal.t_true >= nominal.t_start + 20 * DAY
    np.testing.assert_array_equal(tn, tb)
    untouched = ~late | (kind == "optical")
    np.testing.assert_array_equal(vn[untouched], vb[untouched])
    rng = late & (kind == "range")
    dop = late & (kind == "doppler")
    np.testing.assert_allclose(vb[rng, 0] - vn[rng, 0], r_m * 1e-3, atol=1e-7)
    # One-way convention f_D = -(F/c) range rate: +d mHz of Doppler is -d x 0.0357 mm/s.
    np.testing.assert_allclose(vb[dop, 0] - vn[dop, 0], -d_mhz * MHZ_TO_KM_S, rtol=1e-6, atol=1e-13)
    assert rng.sum() > 500 and dop.sum() > 5000


def test_clock_bias_is_consistent_between_range_doppler_and_tags(nominal):
    bad = faulted("clock-bias")
    kind, tn, tb, vn, vb = _compare(nominal, bad)
    (f,) = FAULT_PRESETS["clock-bias"][1]
    t_on = nominal.t_start + f.onset_day * DAY
    t = nominal.t_true
    before = t < t_on
    np.testing.assert_array_equal(vn[before], vb[before])
    np.testing.assert_array_equal(tn[before], tb[before])
    step = f.phase_s + f.frequency * (t - t_on)
    late = ~before
    # Time tags of every kind move with the clock.
    np.testing.assert_allclose(tb[late] - tn[late], step[late], rtol=0, atol=2.5e-7)
    # Range jumps by c x (phase step + frequency step x elapsed time).
    rng = late & (kind == "range")
    np.testing.assert_allclose(vb[rng, 0] - vn[rng, 0], C_KM_S * step[rng], rtol=0, atol=1e-7)
    # Doppler counts wholly after the step are offset by c x frequency step.
    dop = (t - 60.0 >= t_on) & (kind == "doppler")
    # (float64 resolves ranges of 1e8 km to 1.5e-8 km: 60 s differences carry ~1e-9 km/s.)
    np.testing.assert_allclose(vb[dop, 0] - vn[dop, 0], C_KM_S * f.frequency, rtol=0, atol=2e-9)
    assert np.mean(vb[dop, 0] - vn[dop, 0]) == pytest.approx(C_KM_S * f.frequency, rel=1e-3)
    opt = late & (kind == "optical")
    np.testing.assert_array_equal(vn[opt], vb[opt])
    # The truth clock shows the step.
    k = int(np.searchsorted([x.t_s for x in nominal.truth], t_on + DAY))
    assert bad.truth[k].clock_phase_s - nominal.truth[k].clock_phase_s == pytest.approx(
        f.phase_s + f.frequency * (nominal.truth[k].t_s - t_on), abs=1e-15)
    assert bad.truth[k].clock_frequency - nominal.truth[k].clock_frequency == pytest.approx(f.frequency, rel=1e-6)


@pytest.mark.parametrize("name", ["thruster-mismodel", "thruster-scale"])
def test_thruster_faults_change_the_dynamics_from_onset_only(nominal, name):
    bad = faulted(name)
    t_on = nominal.t_start + 20 * DAY
    # Before onset the streams are identical; after it the changed trajectory may change which
    # target is visible, but every slot seen in both keeps its noise draws.
    n_before = int(np.sum(nominal.t_true < t_on))
    assert nominal.measurements[:n_before] == bad.measurements[:n_before]
    assert bad.t_true[n_before] >= t_on
    for sensor in ("radio", "optical"):
        a, b = getattr(nominal, sensor), getattr(bad, sensor)
        common, ia, ib = np.intersect1d(a.slot * 8 + (a.kind == "doppler" if sensor == "radio" else 0),
                                        b.slot * 8 + (b.kind == "doppler" if sensor == "radio" else 0),
                                        return_indices=True)
        assert common.size > 0.95 * len(a)
        if sensor == "radio":
            np.testing.assert_array_equal(a.noise[ia], b.noise[ib])
        else:
            late = a.t_rx[ia] >= t_on
            same_target = a.target[ia] == b.target[ib]
            np.testing.assert_array_equal(a.noise[ia][~late], b.noise[ib][~late])
            assert same_target.mean() > 0.95
    tt = np.array([x.t_s for x in nominal.truth])
    pn = np.array([x.position_km for x in nominal.truth])
    pb = np.array([x.position_km for x in bad.truth])
    an = np.array([x.acs_accel_km_s2 for x in nominal.truth])
    ab = np.array([x.acs_accel_km_s2 for x in bad.truth])
    np.testing.assert_array_equal(pn[tt < t_on], pb[tt < t_on])
    np.testing.assert_array_equal(an[tt < t_on], ab[tt < t_on])
    late = tt >= t_on + 5 * DAY
    assert np.all(np.linalg.norm(pb[late] - pn[late], axis=1) > 1e-3)
    assert [x.active_faults for x in bad.truth if x.t_s >= t_on][0] == (f"{name}-0",)
    nom_mag = nominal.config.forces.acs_nominal_km_s2
    real_n = nominal.trajectory.realisation
    real_b = bad.trajectory.realisation
    t_mid = 0.5 * (real_b.acs_edges[:-1] + real_b.acs_edges[1:])
    mn = real_n.acs_magnitudes_at(t_mid)
    mb = real_b.acs_magnitudes_at(t_mid)
    on = t_mid >= t_on
    np.testing.assert_array_equal(mn[~on], mb[~on])
    if name == "thruster-scale":
        np.testing.assert_allclose(mb[on] / mn[on], 10.0, rtol=1e-12)
        ratio = np.linalg.norm(ab[late], axis=1) / np.linalg.norm(an[late], axis=1)
        np.testing.assert_allclose(ratio, 10.0, rtol=1e-9)
    else:
        # m = nominal (1 + s_b beta + s_d delta_k) with the same beta, delta_k: nominal sigmas
        # (0.03, 0.05), faulted (3, 10), so x_f - 200 x_n = -3 beta is the same every day.
        xn, xb = mn[on] / nom_mag - 1.0, mb[on] / nom_mag - 1.0
        c = xb - 200.0 * xn
        np.testing.assert_allclose(c, np.broadcast_to(c[0], c.shape), atol=1e-9)
        assert np.std(xb) > 1.0  # dispersions of order 3-10 x nominal
    events = bad.fault_events
    assert [(e.fault_type, e.event, e.fault_class) for e in events] == [(name, "start", "dynamics")]
    assert events[0].t_s == pytest.approx(t_on)


def test_fault_events_and_active_faults_are_recorded(nominal):
    bad = faulted("radio-bias-medium")
    assert nominal.fault_events == [] and all(t.active_faults == () for t in nominal.truth)
    ev = bad.fault_events
    assert [(e.fault_id, e.fault_class) for e in ev] == [("range-bias-0", "radiometric-measurement"),
                                                         ("doppler-bias-1", "radiometric-measurement")]
    t_on = bad.t_start + 20 * DAY
    for t in bad.truth[::50]:
        assert t.active_faults == (("range-bias-0", "doppler-bias-1") if t.t_s >= t_on else ())

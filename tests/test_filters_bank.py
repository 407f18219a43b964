"""The EKF bank: records for every filter, refusal of bad input, commands, presets, SPD."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fsw.filters.bank import FilterBank
from fsw.filters.config import BankConfig, FilterConfig
from fsw.filters.errors import MeasurementRejected, UnknownFilter
from fsw.filters.kalman import is_spd
from fsw.filters.presets import PRESETS, preset
from fsw.filters.radiometric_kinds import doppler_clock_variance, predict_doppler
from fsw.interface.typed import decode, encode
from fsw.models.environment import Environment
from tools.bench.synthetic import make_run

ENV = Environment()


@pytest.fixture(scope="module")
def run():
    return make_run(span_days=2.0, max_measurements=260, env=ENV)


def _bank(run, name="nominal", seed=0) -> FilterBank:
    rng = np.random.default_rng(seed)
    return FilterBank(preset(name), run.t0, run.position_km + rng.normal(0, 20.0, 3),
                      run.velocity_km_s + rng.normal(0, 2e-5, 3), env=ENV)


def test_every_filter_gets_statistics_for_every_measurement(run):
    bank = _bank(run)
    seen = set()
    for m in run.measurements:
        rec = bank.process(m)
        assert rec.filters == ("radio", "optical", "fused") and rec.seq == m.seq and rec.t == m.t_s
        assert rec.residual.shape == (3, len(m.value)) and rec.S.shape == (3, len(m.value), len(m.value))
        assert np.all(np.isfinite(rec.chi2)) and np.all(rec.chi2 >= 0.0)
        expect = {"range": [True, False, True], "doppler": [True, False, True], "optical": [False, True, True]}[m.kind]
        assert rec.processed.tolist() == expect
        for S in rec.S:
            np.linalg.cholesky(S)
        seen.add(m.kind)
        for i in range(3):
            assert is_spd(bank.stack.P[i])
    assert seen == {"range", "doppler", "optical"}
    # the bank converged on the generating trajectory
    truth = run.truth[run.measurements[-1].t_s]
    fused = bank.filter("fused")
    assert np.linalg.norm(fused.position_km - truth[:3]) < 3.0 * fused.position_sigma_km
    assert fused.position_sigma_km < bank.position_sigma_km("radio")
    assert fused.position_sigma_km < bank.position_sigma_km("optical")


def test_filter_layouts_drop_blocks_they_do_not_estimate(run):
    bank = _bank(run)
    assert "clock_phase" not in bank.filter("optical").state_names
    assert "range_bias" in bank.filter("radio").state_names
    assert bank.filter("optical").P.shape == (len(bank.filter("optical").state_names),) * 2


def _meas(run, kind, **changes):
    m = next(m for m in run.measurements if m.kind == kind)
    return dataclasses.replace(m, **changes) if changes else m


@pytest.mark.parametrize(
    "kind, changes, reason",
    [
        ("range", {"value": (float("nan"),)}, "non_finite"),
        ("range", {"t_s": float("inf")}, "non_finite"),
        ("optical", {"value": (1.0,), "sigma": (1.0,)}, "bad_dimension"),
        ("range", {"kind": "generic-linear"}, "unknown_kind"),
        ("range", {"source": "DSS-99"}, "unknown_source"),
        ("optical", {"source": "ganymede"}, "unknown_source"),
        ("doppler", {"count_time_s": None}, "bad_count_time"),
        ("optical", {"attitude_q": (0.0, 0.0, float("nan"), 1.0)}, "non_finite"),
        ("range", {"sigma": (float("nan"),)}, "non_finite"),
    ],
)
def test_bad_measurements_are_refused_before_touching_state(run, kind, changes, reason):
    bank = _bank(run)
    bank.process(run.measurements[0])
    m = _meas(run, kind)
    bad = object.__new__(type(m))  # bypass the ICD's own checks: the bank must not rely on them
    for f in dataclasses.fields(m):
        object.__setattr__(bad, f.name, changes.get(f.name, getattr(m, f.name)))
    x, P, t = bank.stack.x.copy(), bank.stack.P.copy(), bank.t
    with pytest.raises(MeasurementRejected) as err:
        bank.process(bad)
    assert err.value.reason == reason
    assert bank.rejected[reason] == 1
    np.testing.assert_array_equal(bank.stack.x, x)
    np.testing.assert_array_equal(bank.stack.P, P)
    assert bank.t == t


def test_time_running_backwards_is_refused(run):
    bank = _bank(run)
    bank.process(run.measurements[5])
    with pytest.raises(MeasurementRejected) as err:
        bank.process(run.measurements[2])
    assert err.value.reason == "out_of_order" and bank.rejected["out_of_order"] == 1


def test_disable_enable_and_runtime_noise_changes(run):
    bank = _bank(run)
    bank.set_enabled("fused", False)
    x_before = bank.stack.x[2].copy()
    rec = bank.process(_meas(run, "range"))
    assert not rec.active[2] and not rec.processed[2]
    assert np.allclose(bank.stack.x[2, 6:], x_before[6:])  # propagated, not updated
    bank.set_enabled("fused", True)
    with pytest.raises(UnknownFilter):
        bank.set_enabled("nope", True)
    # R scale: the innovation variance of a range grows by the scaled noise variance
    m = next(m for m in run.measurements if m.kind == "range" and m.t_s > rec.t)
    bank.propagate_to(m.t_s)
    h, H = bank.predict(m)
    base = bank.process(m).S[0, 0, 0]
    bank2 = _bank(run)
    bank2.process(_meas(run, "range"))
    bank2.set_param("radio", "sigma_scale.range", 3.0)
    bank2.propagate_to(m.t_s)
    scaled = bank2.process(m).S[0, 0, 0]
    assert scaled - base == pytest.approx(8.0 * m.sigma[0] ** 2, rel=1e-3)
    bank2.set_param("radio", "acs.temporal_sigma", 0.5)
    bank2.set_param("fused", "velocity_noise_psd", 1e-18)
    with pytest.raises(ValueError):
        bank2.set_param("optical", "clock.q_white_fm", 1e-25)  # the optical filter has no clock
    with pytest.raises(ValueError):
        bank2.set_param("radio", "no.such.param", 1.0)


def test_a_gate_set_by_telecommand_edits_the_next_measurement(run):
    """gate_chi2 set at run time applies from the next measurement on (the bank keeps the gates
    it reads per measurement, so the setting must reach them); <= 0 turns editing off again."""
    bank = _bank(run)
    ranges = [m for m in run.measurements if m.kind == "range"]
    rec = bank.process(ranges[0])
    assert rec.processed[0]
    bank.set_param("radio", "gate_chi2", 1e-12)  # every residual is above it
    rec = bank.process(ranges[1])
    assert not rec.processed[0] and rec.processed[2] and rec.chi2[0] > 1e-12
    bank.set_param("radio", "gate_chi2", 0.0)
    assert bank.process(ranges[2]).processed[0]


def test_combined_and_best_estimates(run):
    bank = _bank(run)
    for m in run.measurements[:40]:
        bank.process(m)
    est = bank.estimates(weights=[0.2, 0.3, 0.5])
    comb = est["combined"]
    assert "clock_phase" not in comb.state_names  # not estimated by the optical filter
    xs = np.array([bank.filter(n).x[:6] for n in bank.names])
    np.testing.assert_allclose(comb.x[:6], np.array([0.2, 0.3, 0.5]) @ xs)
    assert est["best"].name == "fused"
    assert comb.position_sigma_km >= min(bank.position_sigma_km(n) for n in bank.names) * 0.5


def test_combined_estimate_of_every_subset_of_weighted_filters(run):
    """The combined estimate over the filters with weight and the states they all estimate:
    the same bits as selecting them with boolean masks, whichever filters have weight (the
    selection is kept per subset), and the mixture of Chaer et al. 1997 eq. 3 computed apart."""
    from fsw.filters.combine import weighted_estimate

    bank = _bank(run)
    for m in run.measurements[:40]:
        bank.process(m)
    st = bank.stack
    for weights in ([0.2, 0.3, 0.5], [0.0, 0.4, 0.6], [0.5, 0.0, 0.5], [0.0, 0.0, 1.0], [0.7, 0.3, 0.0],
                    [0.2, 0.3, 0.5]):
        w = np.array(weights) / sum(weights)
        used = w > 0.0
        common = np.all(st.present[used], axis=0)
        x_ref, P_ref = weighted_estimate(st.x[:, common][used], st.P[:, common][:, :, common][used], w[used])
        comb = bank.estimates(weights=weights)["combined"]
        assert comb.state_names == tuple(n for n, k in zip(bank.state_names, common) if k)
        assert comb.x.tobytes() == x_ref.tobytes() and comb.P.tobytes() == P_ref.tobytes()
        xs, Ps = st.x[used][:, common], st.P[used][:, common][:, :, common]
        x_mix = sum(wi * xi for wi, xi in zip(w[used], xs))
        P_mix = sum(wi * (Pi + np.outer(xi - x_mix, xi - x_mix)) for wi, xi, Pi in zip(w[used], xs, Ps))
        np.testing.assert_allclose(comb.x, x_mix, rtol=1e-12)
        np.testing.assert_allclose(comb.P, P_mix, rtol=1e-9, atol=1e-12 * np.abs(P_mix).max())
    with pytest.raises(ValueError, match="finite and non-negative"):
        bank.estimates(weights=[0.5, -0.1, 0.6])
    with pytest.raises(ValueError, match="finite and non-negative"):
        bank.estimates(weights=[0.5, float("nan"), 0.5])
    with pytest.raises(ValueError, match="positive weight"):
        bank.estimates(weights=[0.0, 0.0, 0.0])


def test_presets_and_config_round_trip():
    assert set(PRESETS) == {"nominal", "acs-q", "process-noise-q"}
    acs = preset("acs-q")
    assert [f.name for f in acs.filters] == ["radio", "optical", "fused", "radio-Q", "optical-Q", "fused-Q"]
    assert acs.filters[3].acs.magnitude.bias_sigma == 3.0 and acs.filters[3].acs.magnitude.temporal_sigma == 10.0
    assert acs.filters[0].acs.magnitude.bias_sigma == 0.03 and acs.filters[0].acs.magnitude.temporal_sigma == 0.05
    pn = preset("process-noise-q")
    assert {f.accel.sigma_km_s2 for f in pn.filters if not f.name.endswith("-Q")} == {5e-12}
    assert {f.accel.sigma_km_s2 for f in pn.filters if f.name.endswith("-Q")} == {5e-11}
    assert all(f.acs.magnitude.bias_sigma == 0.0 and f.srp.scale.temporal_sigma == 0.0 for f in pn.filters)
    for name in PRESETS:
        cfg = preset(name)
        assert decode(BankConfig, encode(cfg)) == cfg
    with pytest.raises(ValueError):
        BankConfig(filters=(FilterConfig(name="a"), FilterConfig(name="a")))
    with pytest.raises(KeyError):
        preset("unknown")


def test_process_noise_bank_resets_polynomial_batches_daily(run):
    bank = _bank(run, "process-noise-q")
    L = bank.stack.layout
    a = L.slices["accel"]
    o = bank.stack.batch_origin  # the bank's initial epoch unless configured
    t_boundary = o + (np.floor((bank.t - o) / 86400.0) + 1) * 86400.0
    bank.propagate_to(t_boundary - 1.0)
    bank.stack.P[:, a, a] *= 0.25  # as if measurements had shrunk it
    bank.propagate_to(t_boundary)  # the boundary is applied on arrival
    sig = np.sqrt(np.diagonal(bank.stack.P[:, a, a], axis1=1, axis2=2))
    np.testing.assert_allclose(sig[0], 5e-12)
    np.testing.assert_allclose(sig[3], 5e-11)
    assert np.all(bank.stack.P[:, a, 0:6] == 0.0)  # a new batch is uncorrelated with the past


def test_ecrv_batch_step_matches_chaer1998_eq_25_26(run):
    bank = _bank(run)
    s = bank.stack.layout.index("srp_stoch")
    bank.stack.x[:, s] = 0.02
    o = bank.stack.batch_origin  # the bank's initial epoch unless configured
    t_boundary = o + (np.floor((bank.t - o) / 86400.0) + 1) * 86400.0
    bank.propagate_to(t_boundary - 1.0)
    p_before = bank.stack.P[0, s, s]
    bank.propagate_to(t_boundary + 1.0)
    m = np.exp(-86400.0 / (7 * 86400.0))
    assert bank.stack.x[0, s] == pytest.approx(0.02 * m)
    assert bank.stack.P[0, s, s] == pytest.approx(m * m * p_before + 0.03**2 * (1 - m * m))


def test_ekf_covariances_stay_spd_along_a_stream():
    long_run = make_run(span_days=6.0, max_measurements=1500, env=ENV, seed=4)
    bank = FilterBank(preset("acs-q"), long_run.t0, long_run.position_km + 30.0, long_run.velocity_km_s, env=ENV)
    for m in long_run.measurements:
        bank.process(m)
        for P in bank.stack.P:
            assert is_spd(P)
    assert bank.processed_count == 1500


def test_doppler_count_reuses_the_propagation_leg_after_an_update(run):
    """The start of a Doppler count from the last propagation leg (symplectic inverse of its
    STM, corrected for an update at the leg's end) equals propagating the state back."""
    bank = _bank(run)
    st = bank.stack
    t = st.t + 3600.0
    st.propagate_to(t - 60.0)
    st.propagate_to(t)
    L = st.layout
    st.x[:, 0:3] += np.array([0.8, -0.5, 0.3])  # as a measurement update at t would
    st.x[:, 3:6] += 2e-6
    st.x[:, L.slices["srp_bias"]] += 0.01
    assert st._last_leg is not None
    h_leg, H_leg = predict_doppler(st, "DSS-14", t, 60.0, st.x)
    h_back, H_back = predict_doppler(st, "DSS-14", t, 60.0, st.x.copy())  # not the bank state: propagates back
    np.testing.assert_allclose(h_leg, h_back, rtol=0, atol=1e-11)  # km/s; the noise is 1e-7
    scale = np.sqrt(np.diagonal(st.P, axis1=1, axis2=2))
    for i in range(3):
        ref = np.max(np.abs(H_back[i, 0] * scale[i]))
        assert np.max(np.abs((H_leg[i, 0] - H_back[i, 0]) * scale[i])) < 1e-8 * ref


def test_doppler_noise_carries_the_clock_short_term_instability(run):
    bank = _bank(run)
    v = doppler_clock_variance(bank.stack, 60.0)
    # DSAC-class default: white FM 1.6e-15 Allan deviation at one day, σ_y² ∝ 1/τ, plus the
    # random-walk FM that brings the one-day deviation to 2e-15 (σ_y² ∝ τ)
    white = (1.6e-15) ** 2 * 86400.0 / 60.0
    walk = ((2.0e-15) ** 2 - (1.6e-15) ** 2) * 60.0 / 86400.0
    expect = 299792.458**2 * (white + walk)
    assert v[bank.index("radio")] == pytest.approx(expect, rel=1e-12)
    assert np.sqrt(expect) * 1e6 == pytest.approx(0.0182, abs=2e-4)  # mm/s, vs 0.1 mm/s noise
    assert v[bank.index("optical")] == 0.0  # no clock states, no clock model


def test_batches_count_from_the_initial_epoch_unless_configured(run):
    bank = _bank(run)
    assert bank.stack.batch_origin == run.t0
    cfg = dataclasses.replace(preset("nominal"), batch_origin_tdb_s=0.0)
    other = FilterBank(cfg, run.t0, run.position_km, run.velocity_km_s, env=ENV)
    assert other.stack.batch_origin == 0.0
    boundary = (np.floor(run.t0 / 86400.0) + 1) * 86400.0
    assert other.stack._events(run.t0 + 86400.0)[0] == boundary
    assert bank.stack._events(run.t0 + 86400.0)[0] == run.t0 + 86400.0


def test_presets_flag_the_high_process_noise_filters():
    for name in ("acs-q", "process-noise-q"):
        flags = {f.name: f.high_q for f in preset(name).filters}
        assert flags == {"radio": False, "optical": False, "fused": False,
                         "radio-Q": True, "optical-Q": True, "fused-Q": True}
    assert not any(f.high_q for f in preset("nominal").filters)


def test_acs_direction_states_follow_lubey_ely_table_1(run):
    bank = _bank(run)
    L = bank.stack.layout
    tilt = L.slices["acs_tilt"]
    np.testing.assert_allclose(np.sqrt(np.diagonal(bank.stack.P[:, tilt, tilt], axis1=1, axis2=2)), np.radians(3.0))
    # the process-noise filters replace the ACS model by a polynomial acceleration
    pn = FilterBank(preset("process-noise-q"), run.t0, run.position_km, run.velocity_km_s, env=ENV)
    assert not pn.stack.layout.has("acs_tilt")

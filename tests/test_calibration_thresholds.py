"""Calibration to a target false-alarm rate, checked out of sample with the real detector."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fsw.fdir.config import config_from_yaml, config_to_yaml
from fsw.fdir.detector import AnomalyDetector
from fsw.fdir.persistence import KOfN, critical_value
from fsw.interface.yamlconfig import ConfigError
from tools.calibration.__main__ import main
from tools.calibration.thresholds import (
    CalibrationError,
    calibrate,
    evaluate_false_alarms,
    false_alarm_prediction_interval,
    holdout_check,
)
from test_fdir_synthetic import BANK3, BANK6, names, simulate_chi2


def magill_like(rng, n_runs, n_batches, nominal=(0.04, 0.03, 0.93), rho=0.7, s=0.25):
    """Weights that prefer the fused filter on nominal runs: softmax of an AR(1) around log-nominal."""
    base = np.log(nominal)
    x = np.zeros((n_runs, 3))
    out = np.empty((n_runs, n_batches, 3))
    for k in range(n_batches):
        x = rho * x + s * np.sqrt(1 - rho**2) * rng.normal(size=(n_runs, 3))
        z = base + x
        e = np.exp(z - z.max(axis=1, keepdims=True))
        out[:, k] = e / e.sum(axis=1, keepdims=True)
    return out


# -- building blocks against independent computations ---------------------------------------------


@pytest.mark.parametrize("k, n", [(1, 1), (2, 3), (3, 5), (5, 5)])
def test_critical_value_matches_brute_force_detector(k, n):
    rng = np.random.default_rng(k * 10 + n)
    for _ in range(20):
        d = rng.gamma(2.0, 1.0, size=int(rng.integers(3, 40)))
        c = critical_value(d, k, n)

        def declares(h):
            window = KOfN(k, n)
            return any(window.push(x > h) for x in d)

        if np.isfinite(c):
            assert declares(c - 1e-9) and not declares(c)
        else:
            assert not declares(-1e9)


def test_prediction_interval_is_the_order_statistic_law():
    """Threshold = j-th largest of R i.i.d. critical values; the count of M fresh units above it,
    simulated directly, has the beta-binomial quantiles the report uses."""
    rng = np.random.default_rng(12)
    r, j, m, trials = 199, 10, 300, 20000
    u = np.sort(rng.random((trials, r)), axis=1)[:, r - j]  # j-th largest of R uniforms
    counts = rng.binomial(m, 1.0 - u)
    report = type("R", (), {"method": "empirical", "rank": j, "units": r})()
    lo, hi = false_alarm_prediction_interval(report, m, 0.90)
    inside = np.mean((counts >= lo) & (counts <= hi))
    assert 0.90 <= inside <= 0.94
    assert np.mean(1.0 - u) == pytest.approx(j / (r + 1), rel=0.02)


# -- the false-alarm target is met on held-out nominal runs -----------------------------------------


@pytest.mark.parametrize("statistic", ["mahalanobis", "max-z"])
@pytest.mark.parametrize("bank", [BANK3, BANK6], ids=["bank3", "bank6"])
def test_held_out_false_alarm_rate_matches_target(statistic, bank):
    target = 0.05
    train = simulate_chi2(np.random.default_rng(1001), bank, 400, 60)
    held = simulate_chi2(np.random.default_rng(2002), bank, 400, 60)
    config, report = calibrate(list(train), target, network="chi2", filters=names(bank), statistic=statistic)
    assert report.method == "empirical" and report.units == 400
    assert report.expected_fa == pytest.approx(20 / 401)
    assert report.false_alarms == 19 and report.fa_ci[0] < target < report.fa_ci[1]
    assert config.clear_threshold < config.threshold
    est = evaluate_false_alarms(config, list(held), bank)
    assert est.units == 400
    lo, hi = false_alarm_prediction_interval(report, est.units, 0.95)
    assert lo <= est.false_alarms <= hi, (est, lo, hi)


def test_holdout_check_counts_what_the_critical_values_say():
    """The hold-out check runs the real detector; a run declares exactly when its critical value
    under the calibrated band exceeds the threshold, which is computed here the other way."""
    from fsw.fdir.statistic import NominalBand

    train = simulate_chi2(np.random.default_rng(71), BANK3, 200, 40)
    held = simulate_chi2(np.random.default_rng(72), BANK3, 120, 40)
    config, report = calibrate(list(train), 0.1, network="chi2", filters=names(BANK3))
    check = holdout_check(config, report, list(held), BANK3)
    band = NominalBand.from_samples(np.concatenate(list(train)), config.spread_floor, config.statistic)
    crit = np.array([critical_value(band.deviation(w), 3, 5) for w in held])
    assert check.units == 120 and check.false_alarms == int(np.sum(crit > config.threshold))
    assert check.predicted == false_alarm_prediction_interval(report, 120, 0.95)
    assert check.inside == (check.predicted[0] <= check.false_alarms <= check.predicted[1])
    # a threshold far too low must come out of its interval
    low = dataclasses.replace(config, threshold=0.2 * config.threshold, clear_threshold=0.1 * config.threshold,
                              onset_reference=0.05 * config.threshold)
    bad = holdout_check(low, report, list(held), BANK3)
    assert bad.false_alarms > check.false_alarms and not bad.inside


def test_false_alarm_rate_per_segment():
    train = simulate_chi2(np.random.default_rng(31), BANK3, 100, 125)
    held = simulate_chi2(np.random.default_rng(32), BANK3, 100, 125)
    config, report = calibrate(list(train), 0.05, network="chi2", filters=names(BANK3), warmup=5, segment_batches=30)
    assert report.units == 400 and config.segment_batches == 30
    est = evaluate_false_alarms(config, list(held))
    lo, hi = false_alarm_prediction_interval(report, est.units, 0.95)
    assert est.units == 400 and lo <= est.false_alarms <= hi, (est, lo, hi)


def test_non_uniform_nominal_is_learned():
    """Magill-like weights: a uniform 1/N band would alarm on every run; the learned one does not."""
    train = magill_like(np.random.default_rng(41), 400, 60)
    held = magill_like(np.random.default_rng(42), 400, 60)
    config, report = calibrate(list(train), 0.05, network="magill", filters=names(BANK3))
    np.testing.assert_allclose(config.nominal_mean, train.mean(axis=(0, 1)), rtol=1e-12)
    est = evaluate_false_alarms(config, list(held), BANK3)
    lo, hi = false_alarm_prediction_interval(report, est.units, 0.95)
    assert lo <= est.false_alarms <= hi, (est, lo, hi)
    uniform = dataclasses.replace(config, nominal_mean=(1 / 3,) * 3)
    assert evaluate_false_alarms(uniform, list(held[:20])).rate == 1.0
    # an optical-type fault: the radio-only filter gains weight it never has nominally
    w = held[0].copy()
    w[30:, 0] += 0.25
    w[30:, 2] -= 0.25
    det = AnomalyDetector(config, BANK3)
    states = [det.update(float(k), wk, names(BANK3)) for k, wk in enumerate(w)]
    assert states[-1].flag and states[-1].anomaly_class == "optical-measurement"
    assert abs(states[-1].onset_t - 30) <= 2


def test_few_runs_fall_back_to_a_tail_fit():
    train = simulate_chi2(np.random.default_rng(51), BANK3, 40, 60)
    held = simulate_chi2(np.random.default_rng(52), BANK3, 400, 60)
    config, report = calibrate(list(train), 0.01, network="chi2", filters=names(BANK3))
    assert report.method == "gumbel" and report.expected_fa == 0.01
    est = evaluate_false_alarms(config, list(held))
    assert est.ci[0] <= 0.03, est  # the Gumbel extrapolation errs on the conservative side here
    with pytest.raises(CalibrationError):
        calibrate(list(train[:5]), 0.01, network="chi2", filters=names(BANK3))


@pytest.mark.parametrize(
    "histories, kwargs",
    [
        ([np.full((10, 2), 0.5)], {}),  # wrong number of filters
        ([np.full((10, 3), np.nan)], {}),
        ([np.full((3, 3), 1 / 3)], {"warmup": 5}),  # nothing left after warm-up
    ],
)
def test_bad_histories_are_rejected(histories, kwargs):
    with pytest.raises(CalibrationError):
        calibrate(histories, 0.05, network="chi2", filters=names(BANK3), **kwargs)


# -- configuration file and command -----------------------------------------------------------------


def test_config_yaml_round_trip_and_validation():
    train = simulate_chi2(np.random.default_rng(61), BANK6, 100, 40)
    config, _ = calibrate(list(train), 0.05, network="chi2", filters=names(BANK6))
    assert config_from_yaml(config_to_yaml(config)) == config
    text = config_to_yaml(config)
    assert f"clear_threshold: {config.clear_threshold}" in text
    with pytest.raises(ConfigError, match="consistent values"):
        config_from_yaml(text.replace(f"clear_threshold: {config.clear_threshold}", "clear_threshold: 99.0"))
    with pytest.raises(ConfigError, match=r"<string>:\d+: persistence_k"):
        config_from_yaml(text.replace("persistence_k: 3", "persistence_k: 0"))


def test_calibration_command(tmp_path, capsys):
    train = simulate_chi2(np.random.default_rng(71), BANK3, 200, 40)
    runs = tmp_path / "nominal.npz"
    np.savez(runs, filters=np.array(names(BANK3)), weights=train)
    out, rep = tmp_path / "chi2.yaml", tmp_path / "report.yaml"
    assert main([str(runs), "--network", "chi2", "--target-fa", "0.05", "--out", str(out), "--report", str(rep)]) == 0
    config = config_from_yaml(out.read_text())
    expected, _ = calibrate(list(train), 0.05, network="chi2", filters=names(BANK3))
    assert config == expected
    assert "false_alarms" in capsys.readouterr().out and rep.exists()
    few = tmp_path / "few.npz"
    np.savez(few, filters=np.array(names(BANK3)), **{f"run_{i:03d}": train[i] for i in range(5)})
    assert main([str(few), "--network", "chi2", "--target-fa", "0.01", "--out", str(out)]) == 2
    assert "cannot support" in capsys.readouterr().err

"""Anomaly detector: declaration, class, onset, hysteresis, clearing, reset, bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tools.calibration.thresholds import calibrate
from fsw.fdir.config import DetectorConfig
from fsw.fdir.detector import AnomalyDetector
from fsw.fdir.errors import FdirInputError
from fsw.fdir.families import FilterFamily
from fsw.gating.base import WeightsUpdate
from test_fdir_synthetic import (
    BANK3,
    BANK6,
    names,
    optical_bias,
    radio_bias,
    ramp_weights,
    simulate_chi2,
    thruster_mismodel,
)

SIGMA = 0.008


def hand_config(n=3, **over) -> DetectorConfig:
    """Uniform nominal band, per-filter sigma SIGMA, weights constrained to sum to one."""
    cov = SIGMA**2 * (np.eye(n) - np.ones((n, n)) / n)
    base = dict(
        network="chi2", filters=tuple(f.name for f in (BANK3 if n == 3 else BANK6)),
        nominal_mean=(1.0 / n,) * n, nominal_cov=tuple(map(tuple, cov)),
        threshold=3.5, clear_threshold=2.5, onset_reference=2.0,
        persistence_k=3, persistence_n=5, hold=4,
    )
    base.update(over)
    return DetectorConfig(**base)


def run(det: AnomalyDetector, weights: np.ndarray, filters, t0: float = 0.0, dt: float = 3600.0):
    return [det.update(t0 + k * dt, w, filters) for k, w in enumerate(weights)]


@pytest.fixture(scope="module")
def chi2_configs():
    rng = np.random.default_rng(20240601)
    out = {}
    for key, bank in (("bank3", BANK3), ("bank6", BANK6)):
        nominal = simulate_chi2(rng, bank, 400, 60)
        out[key], _ = calibrate(list(nominal), 0.01, network="chi2", filters=names(bank))
    return out


# -- detection and characterization on chi-square gating weights ----------------------------------


def test_no_declaration_on_nominal_runs(chi2_configs):
    rng = np.random.default_rng(99)
    for bank, key in ((BANK3, "bank3"), (BANK6, "bank6")):
        for weights in simulate_chi2(rng, bank, 15, 60):
            states = run(AnomalyDetector(chi2_configs[key], bank), weights, names(bank))
            assert not any(s.flag for s in states)
            assert all(s.anomaly_class == "none" and s.confidence == 0.0 for s in states)


@pytest.mark.parametrize(
    "bank, key, fault, expected",
    [
        (BANK3, "bank3", optical_bias(3000.0), "optical-measurement"),
        (BANK3, "bank3", radio_bias(300.0), "radiometric-measurement"),  # Table 3 large radio: ~0.37 vs 0.31
        (BANK6, "bank6", optical_bias(3000.0), "optical-measurement"),
        (BANK6, "bank6", thruster_mismodel(3000.0, 300.0), "dynamics"),
    ],
)
def test_fault_is_declared_with_class_and_onset(chi2_configs, bank, key, fault, expected):
    rng = np.random.default_rng(5)
    onset_batch, dt = 30, 3600.0
    for weights in simulate_chi2(rng, bank, 6, 50, fault=fault, onset=onset_batch):
        states = run(AnomalyDetector(chi2_configs[key], bank), weights, names(bank), dt=dt)
        first = next(i for i, s in enumerate(states) if s.flag)
        assert onset_batch <= first <= onset_batch + 4  # persistence k=3 of 5
        final = states[-1]
        assert final.flag and final.anomaly_class == expected
        assert final.confidence > 0.95
        assert abs(final.onset_t - onset_batch * dt) <= 2 * dt
        assert final.declared_t == first * dt
        assert set(final.evidence) == set(names(bank))
        np.testing.assert_allclose([final.evidence[n] for n in names(bank)], weights[-1])


def test_small_radio_bias_absorbed_by_clock_is_not_declared(chi2_configs):
    """Lubey & Ely 2022 Table 3: small/medium radio biases leave the weights at their nominal values."""
    rng = np.random.default_rng(17)
    for weights in simulate_chi2(rng, BANK3, 10, 60, fault=radio_bias(5.0), onset=10):
        assert not any(s.flag for s in run(AnomalyDetector(chi2_configs["bank3"], BANK3), weights, names(BANK3)))


# -- family rises to 0.9 / -Q filters rise (direct weight paths) -------------------------------------


@pytest.mark.parametrize(
    "target, expected",
    [
        ([0.90, 0.05, 0.05], "optical-measurement"),  # radio-only preferred
        ([0.05, 0.90, 0.05], "radiometric-measurement"),  # optical-only preferred
        ([0.05, 0.05, 0.90], "unknown"),  # fused preferred: no branch of the tree
    ],
)
def test_family_rise_classified(target, expected):
    rng = np.random.default_rng(1)
    w = ramp_weights(rng, 60, [1 / 3] * 3, target, onset=25, noise=0.5 * SIGMA)
    states = run(AnomalyDetector(hand_config(), BANK3), w, names(BANK3), dt=1.0)
    assert states[-1].flag and states[-1].anomaly_class == expected
    assert abs(states[-1].onset_t - 25) <= 2


def test_high_q_filters_rising_is_dynamics():
    rng = np.random.default_rng(2)
    target = [0.0844, 0.2510, 0.0815, 0.1658, 0.2520, 0.1653]  # Lubey & Ely 2022 Table 4, thruster scenario
    w = ramp_weights(rng, 60, [1 / 6] * 6, target, onset=20, noise=0.5 * SIGMA)
    states = run(AnomalyDetector(hand_config(6), BANK6), w, names(BANK6), dt=1.0)
    assert states[-1].flag and states[-1].anomaly_class == "dynamics"
    assert abs(states[-1].onset_t - 20) <= 2


def test_family_tags_not_names_drive_the_class():
    """Same weights, filters renamed and tagged: the class follows the tags."""
    rng = np.random.default_rng(3)
    w = ramp_weights(rng, 50, [1 / 3] * 3, [0.9, 0.05, 0.05], onset=20, noise=0.5 * SIGMA)
    bank = (
        FilterFamily(name="A", families=("optical",)),
        FilterFamily(name="B", families=("radio",)),
        FilterFamily(name="C", families=("fused",)),
    )
    cfg = hand_config(filters=("A", "B", "C"))
    # the filter taking weight 0.9 is now the optical-only one
    assert run(AnomalyDetector(cfg, bank), w, ("A", "B", "C"))[-1].anomaly_class == "radiometric-measurement"


def test_weight_order_of_the_update_does_not_matter():
    rng = np.random.default_rng(4)
    w = ramp_weights(rng, 50, [1 / 3] * 3, [0.9, 0.05, 0.05], onset=20, noise=0.5 * SIGMA)
    a = run(AnomalyDetector(hand_config(), BANK3), w, names(BANK3))
    perm = [2, 0, 1]
    b = run(AnomalyDetector(hand_config(), BANK3), w[:, perm], tuple(names(BANK3)[i] for i in perm))
    assert a == b


# -- hysteresis, clearing, reset ---------------------------------------------------------------------


def _weights_at_distance(cfg: DetectorConfig, distances: np.ndarray) -> np.ndarray:
    """Weight vectors on the radio-vs-optical direction at the given Mahalanobis distances."""
    n = len(cfg.filters)
    c = np.asarray(cfg.nominal_cov) + cfg.spread_floor**2 * np.eye(n)
    u = np.zeros(n)
    u[0], u[1] = 1.0, -1.0
    unit = np.sqrt(u @ np.linalg.solve(c, u))
    return np.asarray(cfg.nominal_mean) + np.outer(np.asarray(distances) / unit, u)


def test_no_chatter_when_statistic_hovers_at_threshold():
    cfg = hand_config()
    h = cfg.threshold
    # alternating, and stretches of several batches just below the threshold
    hover = np.concatenate([np.tile([1.04 * h, 0.96 * h], 10), np.tile([1.04 * h] * 3 + [0.96 * h] * 6, 5)])
    d = np.concatenate([np.full(10, 0.5), hover])
    w = _weights_at_distance(cfg, d)
    states = run(AnomalyDetector(cfg, BANK3), w, names(BANK3))
    np.testing.assert_allclose([s.statistic for s in states], d, rtol=1e-9)
    crossings = int(np.sum(np.diff(d > h) != 0))
    assert crossings > 25
    flips = int(np.sum(np.diff([s.flag for s in states]) != 0))
    assert flips == 1 and states[-1].flag
    # without a hysteresis band the same input does chatter, so the check above can fail
    for loose in (dataclasses.replace(cfg, clear_threshold=0.999 * h), dataclasses.replace(cfg, clear_threshold=0.999 * h, hold=1)):
        states = run(AnomalyDetector(loose, BANK3), w, names(BANK3))
        assert int(np.sum(np.diff([s.flag for s in states]) != 0)) >= 5


def test_persistence_needs_k_of_n():
    cfg = hand_config()  # k = 3 of n = 5
    h = cfg.threshold
    base = np.full(30, 0.5)
    two_in_five = base.copy()
    two_in_five[[10, 13, 17, 20]] = 2 * h  # never three within five batches
    three_in_five = base.copy()
    three_in_five[[10, 12, 14]] = 2 * h
    flags = [s.flag for s in run(AnomalyDetector(cfg, BANK3), _weights_at_distance(cfg, two_in_five), names(BANK3))]
    assert not any(flags)
    flags = [s.flag for s in run(AnomalyDetector(cfg, BANK3), _weights_at_distance(cfg, three_in_five), names(BANK3))]
    assert flags.index(True) == 14


def test_onset_is_found_by_looking_back_from_a_late_declaration():
    """A slow drift crosses the threshold late; the CUSUM look-back still finds its start."""
    cfg = hand_config()
    rng = np.random.default_rng(11)
    for _ in range(5):
        w = ramp_weights(rng, 70, [1 / 3] * 3, [1 / 3 - 0.09, 1 / 3 + 0.18, 1 / 3 - 0.09], onset=30, tau=40.0, noise=0.5 * SIGMA)
        states = run(AnomalyDetector(cfg, BANK3), w, names(BANK3), dt=1.0)
        declared = next(s for s in states if s.flag)
        assert declared.declared_t - 30 >= 4
        assert abs(declared.onset_t - 30) <= 2


def test_clears_when_weights_return_to_nominal_and_rearms():
    cfg = hand_config()
    rng = np.random.default_rng(6)
    first = ramp_weights(rng, 60, [1 / 3] * 3, [0.05, 0.9, 0.05], onset=10, end=30, noise=0.5 * SIGMA)
    second = ramp_weights(rng, 40, [1 / 3] * 3, [0.9, 0.05, 0.05], onset=10, noise=0.5 * SIGMA)
    det = AnomalyDetector(cfg, BANK3)
    states = run(det, np.concatenate([first, second]), names(BANK3), dt=1.0)
    flags = np.array([s.flag for s in states])
    assert flags[15:30].all()
    cleared_at = next(k for k in range(30, 60) if not flags[k])
    assert cleared_at <= 30 + 8 + cfg.hold  # recovery transient + hold
    assert not flags[cleared_at:70].any()
    assert states[cleared_at].cleared_t == cleared_at and states[cleared_at].anomaly_class == "none"
    assert states[-1].flag and states[-1].anomaly_class == "optical-measurement"
    assert abs(states[-1].onset_t - 70) <= 2


def test_reset_clears_and_rearms():
    cfg = hand_config(warmup=2)
    rng = np.random.default_rng(7)
    w = ramp_weights(rng, 40, [1 / 3] * 3, [0.9, 0.05, 0.05], onset=5, noise=0.5 * SIGMA)
    det = AnomalyDetector(cfg, BANK3)
    states = run(det, w[:20], names(BANK3), dt=1.0)
    assert states[-1].flag
    after = det.reset()
    assert not after.flag and after.anomaly_class == "none" and after.cleared_t == 19.0
    assert det.state is after
    # the fault persists: warm-up (2) then k = 3 batches before it is declared again
    again = [det.update(20.0 + k, wk, names(BANK3)) for k, wk in enumerate(w[20:])]
    assert [s.flag for s in again[:5]] == [False] * 4 + [True]
    assert again[0].statistic is None and again[4].onset_t == 22.0


def test_disabled_filter_is_judged_on_the_active_ones():
    cfg = hand_config()
    rng = np.random.default_rng(8)
    w = ramp_weights(rng, 40, [0.5, 0.5, 0.0], [0.5, 0.5, 0.0], onset=0, noise=0.5 * SIGMA)
    w[:, 2] = 0.0
    w /= w.sum(axis=1, keepdims=True)
    det = AnomalyDetector(cfg, BANK3)
    active = np.array([True, True, False])
    states = [det.update(float(k), wk, names(BANK3), active=active) for k, wk in enumerate(w)]
    assert not any(s.flag for s in states)
    # the same weights read as a full bank are far from nominal
    assert AnomalyDetector(cfg, BANK3).update(0.0, w[0], names(BANK3)).statistic > 10 * cfg.threshold


def test_single_active_filter_keeps_the_verdict():
    cfg = hand_config()
    rng = np.random.default_rng(10)
    w = ramp_weights(rng, 20, [1 / 3] * 3, [0.9, 0.05, 0.05], onset=5, noise=0.5 * SIGMA)
    det = AnomalyDetector(cfg, BANK3)
    flagged = run(det, w, names(BANK3), dt=1.0)[-1]
    assert flagged.flag
    only_radio = det.update(20.0, [1.0, 0.0, 0.0], names(BANK3), active=[True, False, False])
    assert only_radio.flag and only_radio.anomaly_class == flagged.anomaly_class
    assert only_radio.statistic is None and only_radio.t == 20.0


def test_gating_update_is_consumed_with_its_statistic_as_evidence():
    det = AnomalyDetector(hand_config(), BANK3)
    update = WeightsUpdate(network="chi2", t=5.0, seq=999, batch=0, filters=("fused", "radio", "optical"),
                           weights=np.array([0.3, 0.4, 0.3]), statistic=np.array([1010.0, 990.0, 1005.0]))
    s = det.consume(update)
    assert s.t == 5.0 and s.evidence == {"radio": 0.4, "optical": 0.3, "fused": 0.3}
    assert s.batch_statistic == {"radio": 990.0, "optical": 1005.0, "fused": 1010.0}
    with pytest.raises(FdirInputError):
        det.consume(dataclasses.replace(update, network="magill", t=6.0))


# -- bad input --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(weights=[np.nan, 0.5, 0.5]),
        dict(weights=[0.5, 0.5]),
        dict(weights=[0.5, 0.5, 0.5]),  # does not sum to one
        dict(weights=["a", "b", "c"]),
        dict(filter_names=("radio", "optical", "camera")),
        dict(filter_names=("radio", "optical")),
        dict(filter_names="radio"),
        dict(t=float("nan")),
        dict(t=-1.0),  # earlier than the previous update
        dict(active=[1, 1, 0]),
        dict(batch_statistic=[1.0, 1.0]),
        dict(batch_statistic=[1.0, np.inf, 1.0]),
    ],
)
def test_bad_input_raises_and_leaves_state_untouched(kwargs):
    rng = np.random.default_rng(9)
    w = ramp_weights(rng, 12, [1 / 3] * 3, [0.9, 0.05, 0.05], onset=4, noise=0.5 * SIGMA)
    det, twin = AnomalyDetector(hand_config(), BANK3), AnomalyDetector(hand_config(), BANK3)
    for k in range(8):
        det.update(float(k), w[k], names(BANK3))
        twin.update(float(k), w[k], names(BANK3))
    before = det.state
    call = dict(t=8.0, weights=w[8], filter_names=names(BANK3)) | kwargs
    with pytest.raises(FdirInputError):
        det.update(**call)
    assert det.state is before
    for k in range(8, 12):
        assert det.update(float(k), w[k], names(BANK3)) == twin.update(float(k), w[k], names(BANK3))


def test_family_tags_must_cover_the_bank():
    with pytest.raises(ValueError):
        AnomalyDetector(hand_config(), BANK3[:2])

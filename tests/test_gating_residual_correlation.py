"""Residual-correlation hypothesis testing (Hanlon & Maybeck 2000 eqs. 18–22): periodogram and its nominal
statistics against independent computations, and detection of a periodic residual signature
that a magnitude-only chi-square test at the same false-alarm rate misses."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2 as chi2_dist
from scipy.stats import expon

from fsw.filters.record import BankRecord
from fsw.gating import make_network
from fsw.gating.base import InvalidParameterError
from fsw.gating.residual_correlation import periodogram, white_noise_covariance

NAMES = ("no-thruster-model", "thruster-model")


def test_periodogram_equals_fft_bins():
    rng = np.random.default_rng(0)
    eps = rng.standard_normal((64, 3, 2))
    bins = np.array([1, 5, 13])
    psi = periodogram(eps, np.arange(64.0) + 17.0, bins / 64.0)  # (3, 2, F)
    ref = np.abs(np.fft.fft(eps, axis=0)[bins]) ** 2 / 64.0  # (F, 3, 2)
    np.testing.assert_allclose(psi, np.moveaxis(ref, 0, -1), rtol=1e-10)


def test_white_noise_covariance_matches_monte_carlo():
    rng = np.random.default_rng(1)
    tau = np.sort(rng.uniform(0.0, 3000.0, 80))  # irregular time tags [s]
    freqs = np.array([1 / 600.0, 1 / 400.0, 0.0])
    psi = periodogram(rng.standard_normal((80, 40000, 1)), tau, freqs)[:, 0, :]  # (trials, F)
    np.testing.assert_allclose(psi.mean(axis=0), 1.0, atol=0.03)
    cov = white_noise_covariance(tau, freqs)
    np.testing.assert_allclose(np.cov(psi.T), cov, rtol=0.08, atol=0.03)
    assert cov[2, 2] == pytest.approx(2.0)  # f = 0: ψ ~ χ²₁


def residual_runs(rng, runs, length, amplitude, freq, fault: bool):
    """Normalised residuals (runs, length, 2 filters). Under the fault (periodic thruster firing)
    the filter without a thruster model sees the sinusoid; without the fault the filter that
    models the firings sees their (absent) signature with the opposite sign."""
    k = np.arange(length)
    phase = rng.uniform(0, 2 * np.pi, (runs, 1))
    signal = amplitude * np.sin(2 * np.pi * freq * k + phase)
    eps = rng.standard_normal((runs, length, 2))
    if fault:
        eps[:, :, 0] += signal
    else:
        eps[:, :, 1] -= signal
    return eps


def run_network(eps, params):
    """Probability of the 'thruster-model' hypothesis over time for each run."""
    out = []
    S = np.ones((2, 1, 1))
    for run in eps:
        net = make_network("residual-correlation", NAMES, params)
        probs = []
        for k, e in enumerate(run):
            rec = BankRecord(t=float(k), seq=k, kind="range", filters=NAMES, residual=e[:, None], S=S,
                             chi2=e**2, processed=np.ones(2, bool))
            u = net.update(rec)
            if u is not None:
                probs.append(u.weights[1])
        out.append(probs)
    return np.array(out)


def test_detects_periodic_signature_that_chi_square_misses():
    rng = np.random.default_rng(7)
    window, freq, amplitude, length, runs = 100, 0.05, 0.5, 300, 60
    params = {"window": window, "frequencies": (freq,), "lower_bound": 1e-3}
    nominal = residual_runs(rng, runs, length, amplitude, freq, fault=False)
    faulty = residual_runs(rng, runs, length, amplitude, freq, fault=True)
    # Decision at the end of the run: hypothesis probability above 0.5 (Hanlon & Maybeck's (2000) declaration).
    rc_false_alarm = np.mean(run_network(nominal, params)[:, -1] > 0.5)
    rc_detect = np.mean(run_network(faulty, params)[:, -1] > 0.5)
    # Magnitude-only test on the same residuals: the whole run's chi-square sum of the filter
    # without the thruster model (χ²_T under nominal operation), at the same false-alarm rate
    # (never below 1 %, which only favours the chi-square test).
    alpha = max(rc_false_alarm, 0.01)
    threshold = chi2_dist.ppf(1.0 - alpha, length)
    chi_false_alarm = np.mean(np.sum(nominal[:, :, 0] ** 2, axis=1) > threshold)
    chi_detect = np.mean(np.sum(faulty[:, :, 0] ** 2, axis=1) > threshold)
    print(f"residual-correlation: false alarms {rc_false_alarm:.3f}, detections {rc_detect:.3f}; "
          f"chi-square at alpha={alpha:.3f} (threshold {threshold:.1f}): false alarms {chi_false_alarm:.3f}, "
          f"detections {chi_detect:.3f}")
    assert rc_false_alarm <= 0.05
    assert rc_detect >= 0.9
    assert chi_detect <= 0.3


def test_learned_calibration_and_kind_selection():
    rng = np.random.default_rng(3)
    params = {"window": 50, "frequencies": (0.1,), "calibration": "learn", "calibration_count": 200,
              "kind": "range"}
    net = make_network("residual-correlation", NAMES, params)
    S = np.ones((2, 1, 1))
    k_total = 0

    def feed(eps_pair, kind="range"):
        nonlocal k_total
        rec = BankRecord(t=float(k_total), seq=k_total, kind=kind, filters=NAMES, residual=eps_pair[:, None],
                         S=S, chi2=eps_pair**2, processed=np.ones(2, bool))
        k_total += 1
        return net.update(rec)

    # Nominal span: both filters white. Nothing is produced until 200 windows are learned.
    outs = [feed(rng.standard_normal(2)) for _ in range(248)]
    assert all(o is None for o in outs) and not net.state_dict()["calibrated"]
    assert feed(rng.standard_normal(2)) is not None and net.state_dict()["calibrated"]
    # Other kinds are ignored.
    assert feed(np.array([50.0, 50.0]), kind="doppler") is None
    # Fault: the no-thruster filter shows the sinusoid.
    for k in range(300):
        e = rng.standard_normal(2)
        e[0] += 0.6 * np.sin(2 * np.pi * 0.1 * k)
        u = feed(e)
    assert u.weights[1] > 0.9
    net.reset()
    np.testing.assert_allclose(net.weights, 0.5)
    assert net.state_dict()["calibrated"]


def feed_all(net, eps):
    """Feed (K, 2 filters, 1) normalised residuals; return the updates (k, weights)."""
    S = np.ones((2, 1, 1))
    out = []
    for k, e in enumerate(eps):
        rec = BankRecord(t=float(k), seq=k, kind="range", filters=NAMES, residual=e, S=S,
                         chi2=e[:, 0] ** 2, processed=np.ones(2, bool))
        u = net.update(rec)
        if u is not None:
            out.append((k, np.asarray(u.weights)))
    return out


def test_disjoint_windows_with_the_exponential_density_match_a_direct_computation():
    rng = np.random.default_rng(11)
    window, freq, K = 40, 0.125, 205
    eps = rng.standard_normal((K, 2, 1))
    eps[:, 0, 0] += 0.4 * np.sin(2 * np.pi * freq * np.arange(K))
    net = make_network("residual-correlation", NAMES, {"window": window, "frequencies": (freq,),
                                                        "update_every": window, "density": "exponential",
                                                        "lower_bound": None})
    ups = feed_all(net, eps)
    # Updates on the records that complete a window, and only then: 39, 79, 119, 159, 199.
    assert [k for k, _ in ups] == [39, 79, 119, 159, 199]
    # Independent: numpy's FFT of each disjoint window at bin freq·N, the exponential log-density
    # (scipy) of each filter's ψ, summed over the windows, normalised from equal priors.
    loglik = np.zeros(2)
    for j, (k, w) in enumerate(ups):
        block = eps[k - window + 1:k + 1, :, 0]
        psi = np.abs(np.fft.fft(block, axis=0)[int(freq * window)]) ** 2 / window
        loglik += expon.logpdf(psi)
        ref = np.exp(loglik - loglik.max())
        np.testing.assert_allclose(w, ref / ref.sum(), rtol=1e-9)
    assert ups[-1][1][1] > 0.99  # the filter whose residuals carry the sinusoid loses


def test_update_every_keeps_the_statistic_and_thins_the_updates():
    rng = np.random.default_rng(12)
    eps = rng.standard_normal((60, 2, 1))
    every = make_network("residual-correlation", NAMES, {"window": 20, "frequencies": (0.1,)})
    thin = make_network("residual-correlation", NAMES, {"window": 20, "frequencies": (0.1,), "update_every": 7})
    a, b = feed_all(every, eps), feed_all(thin, eps)
    assert [k for k, _ in a] == list(range(19, 60))
    assert [k for k, _ in b] == list(range(19, 60, 7))
    np.testing.assert_allclose(every.statistic(), thin.statistic())
    # The first update of both is the same single-window evidence.
    np.testing.assert_allclose(a[0][1], b[0][1])


def test_update_every_and_density_are_validated():
    with pytest.raises(InvalidParameterError, match="update_every"):
        make_network("residual-correlation", NAMES, {"update_every": 0})
    with pytest.raises(InvalidParameterError, match="density"):
        make_network("residual-correlation", NAMES, {"density": "cauchy"})


def test_changing_update_every_keeps_the_window():
    rng = np.random.default_rng(13)
    net = make_network("residual-correlation", NAMES, {"window": 20, "frequencies": (0.1,)})
    feed_all(net, rng.standard_normal((25, 2, 1)))
    before = net.statistic()
    net.set_param("update_every", 5)
    np.testing.assert_allclose(net.statistic(), before)  # no refill of the window
    ups = feed_all(net, rng.standard_normal((10, 2, 1)))
    assert len(ups) == 2  # records 25..34: those 5 and 10 samples after the last update

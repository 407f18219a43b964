"""RQP parameter adaptation (Chaer et al. 1997 §IV eqs. 21-23): likelihood, gradient, optimum, slicing."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.stats import multivariate_normal

from fsw.filters.linear import LinearFilterBank
from fsw.filters.rqp import LinearBankAdaptation, LinearWindow, RqpBounds, RqpSearch, central_gradient
from sim.scenarios import chaer_tracking as ct


def _random_walk(q: float, r: float, K: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(0.0, np.sqrt(q), K))
    return (x + rng.normal(0.0, np.sqrt(r), K))[:, None]


def _reference_nll(F, H, x0, P0, Z, Q, R, predict_first):
    """Plain textbook Kalman filter, one measurement at a time, with scipy's Gaussian density."""
    x, P = np.array(x0, float), np.array(P0, float)
    J = 0.0
    for k, z in enumerate(Z):
        if k > 0 or predict_first:
            x, P = F @ x, F @ P @ F.T + Q
        W = H @ P @ H.T + R
        J -= multivariate_normal(mean=H @ x, cov=W).logpdf(z)
        K = P @ H.T @ np.linalg.inv(W)
        x = x + K @ (z - H @ x)
        P = (np.eye(len(x)) - K @ H) @ P
    return J


@pytest.mark.parametrize("predict_first", [False, True])
def test_nll_matches_independent_filter(predict_first):
    run = ct.experiment_4(np.random.default_rng(3), length=60)
    F, H = np.array(ct.TRANSITION), np.array(ct.MEASUREMENT_MATRIX)
    alphas = np.array([[4.0, 20.0, 25.0, 10.0], [1.0, 1.0, 1.0, 1.0], [50.0, 3.0, 7.0, 40.0]])
    w = LinearWindow(F, H, [0.0, 0.0], ct.FILTER_INITIAL_COVARIANCE, run.z, predict_first)
    got = w.nll(alphas)
    for a, j in zip(alphas, got):
        ref = _reference_nll(F, H, [0.0, 0.0], np.array(ct.FILTER_INITIAL_COVARIANCE), run.z,
                             np.diag(a[:2]), np.diag(a[2:]), predict_first)
        assert j == pytest.approx(ref, rel=1e-9)


def test_batched_central_gradient_matches_scalar_differences():
    w = LinearWindow([[1.0]], [[1.0]], [0.0], [[100.0]], _random_walk(2.0, 5.0, 150, 1), predict_first=False)
    b = RqpBounds((0.01, 0.01), (20.0, 20.0))
    a = np.array([3.0, 4.0])
    g = central_gradient(w, a, b)
    h = 1e-5
    ref = [(w.nll(a + h * e)[0] - w.nll(a - h * e)[0]) / (2 * h) for e in np.eye(2)]
    np.testing.assert_allclose(g, ref, rtol=1e-4)


def test_optimum_matches_brute_force_grid():
    w = LinearWindow([[1.0]], [[1.0]], [0.0], [[100.0]], _random_walk(2.0, 5.0, 300, 1), predict_first=False)
    b = RqpBounds((0.01, 0.01), (20.0, 20.0))
    s = RqpSearch(w, b, np.array([10.0, 1.0]), max_iter=100)
    a = s.run(slice_evaluations=1)  # paused after every evaluation
    qs, rs = np.linspace(0.5, 6.0, 221), np.linspace(1.0, 10.0, 181)
    G = np.array(np.meshgrid(qs, rs, indexing="ij")).reshape(2, -1).T
    J = w.nll(G)
    g = G[np.argmin(J)]
    assert abs(a[0] - g[0]) <= 2 * (qs[1] - qs[0]) and abs(a[1] - g[1]) <= 2 * (rs[1] - rs[0])
    assert s.nll_best <= J.min() + 1e-2  # ftol 1e-6 per measurement: ~3e-4 nat over 300
    assert s.nll_best < s.nll_before - 10.0


def test_optimum_on_the_box_when_the_truth_is_outside():
    w = LinearWindow([[1.0]], [[1.0]], [0.0], [[100.0]], _random_walk(2.0, 5.0, 300, 2), predict_first=False)
    b = RqpBounds((0.01, 0.01), (1.0, 20.0))  # q ≤ 1 while the data say ≈ 2
    a = RqpSearch(w, b, np.array([0.5, 1.0])).run()
    assert a[0] == pytest.approx(1.0, abs=1e-6)
    assert np.all(a >= b.lower) and np.all(a <= b.upper)


def test_each_slice_is_bounded_and_slicing_changes_nothing():
    """Paused after every evaluation or run in one go, the search is scipy's own SLSQP: same path,
    same optimum as ``minimize(method="SLSQP")`` on the same variables (u = ln α, J / P)."""
    w = LinearWindow([[1.0]], [[1.0]], [0.0], [[100.0]], _random_walk(2.0, 5.0, 200, 4), predict_first=False)
    b = RqpBounds((0.01, 0.01), (20.0, 20.0))
    s = RqpSearch(w, b, np.array([15.0, 0.5]))
    while True:
        before = s.evaluations
        done = s.step(2)
        assert s.evaluations - before <= 2 or s.evaluations - before == 4  # one J, or one gradient (2·dim)
        if done:
            break
    whole = RqpSearch(w, b, np.array([15.0, 0.5]))
    whole.run(10_000)
    np.testing.assert_array_equal(s.best, whole.best)
    ref = minimize(lambda u: w.nll(np.exp(u))[0] / 200, np.log([15.0, 0.5]),
                   jac=lambda u: central_gradient(w, np.exp(u), b) * np.exp(u) / 200, method="SLSQP",
                   bounds=list(zip(np.log(b.lower), np.log(b.upper))), options={"ftol": 1e-6, "maxiter": 100})
    assert s.status == ref.status == 0
    np.testing.assert_allclose(np.log(s.best), ref.x, rtol=1e-8)  # exp/log round trips only


def test_search_state_pickles_mid_run():
    w = LinearWindow([[1.0]], [[1.0]], [0.0], [[100.0]], _random_walk(2.0, 5.0, 200, 5), predict_first=False)
    b = RqpBounds((0.01, 0.01), (20.0, 20.0))
    s = RqpSearch(w, b, np.array([15.0, 0.5]))
    for _ in range(4):
        s.step(3)
    s2 = pickle.loads(pickle.dumps(s))
    s.run(3), s2.run(3)
    np.testing.assert_array_equal(s.best, s2.best)


def test_bounds_are_validated():
    with pytest.raises(ValueError):
        RqpBounds((0.0, 1.0), (2.0, 3.0))  # the search runs on ln α: the floor must be positive
    with pytest.raises(ValueError):
        RqpBounds((1.0,), (0.5,))


def _bank() -> LinearFilterBank:
    alpha = ct.bank_parameters(4)
    Q = np.zeros((5, 2, 2))
    R = np.zeros((5, 2, 2))
    Q[:, 0, 0], Q[:, 1, 1], R[:, 0, 0], R[:, 1, 1] = alpha.T
    return LinearFilterBank([f"KF{i}" for i in range(1, 6)], ct.TRANSITION, Q, ct.MEASUREMENT_MATRIX, R,
                            ct.FILTER_INITIAL_STATE, ct.FILTER_INITIAL_COVARIANCE)


def test_bank_adaptation_tunes_the_preferred_filter_and_survives_pickling():
    run = ct.experiment_4(np.random.default_rng(7), length=400)
    bank = _bank()
    b = RqpBounds((1e-3, 1e-3, 0.1, 0.1), (100.0, 100.0, 100.0, 100.0))
    ad = LinearBankAdaptation(bank, b, 200, P_restart=ct.FILTER_INITIAL_COVARIANCE)
    weights = np.array([0.1, 0.1, 0.6, 0.1, 0.1])  # KF3 preferred
    for k, z in enumerate(run.z):
        if k == 205:  # mid-search: the whole adaptation state must round-trip (FSW checkpoints)
            ad = pickle.loads(pickle.dumps(ad))
            bank = ad.bank
        ad.before()
        bank.update(z, t=run.t[k], seq=k) if k == 0 else bank.step(z, t=run.t[k], seq=k)
        ad.after(z, weights, float(run.t[k]))
    first = ad.outcomes[0]
    assert first.filter == "KF3" and first.applied
    assert first.nll_after < first.nll_before
    np.testing.assert_allclose(ad.alpha(2), ad.outcomes[-1].alpha_after if ad.outcomes[-1].applied else ad.alpha(2))
    np.testing.assert_allclose(ad.alpha(0), ct.TABLE_IV[0])  # the others keep their parameters
    assert not np.allclose(ad.alpha(2), ct.TABLE_IV[2])

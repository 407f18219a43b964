"""The linear filter bank against FilterPy, P stays SPD, bad input is refused untouched."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from fsw.filters.errors import MeasurementRejected
from fsw.filters.kalman import is_spd
from fsw.filters.linear import LinearFilterBank
from fsw.interface.messages import Measurement, Stamp


def _system(N=4, n=6, m=2, seed=3, coupling=0.05):
    rng = np.random.default_rng(seed)
    F = np.array([np.eye(n) + coupling * np.triu(rng.standard_normal((n, n)), 1) for _ in range(N)])
    Q = np.array([np.diag(rng.uniform(1e-3, 1e-1, n)) for _ in range(N)])
    H = rng.standard_normal((N, m, n))
    A = rng.standard_normal((N, m, m))
    R = A @ A.transpose(0, 2, 1) + np.eye(m)
    return F, Q, H, R


def _filterpy(F, Q, H, R, x0, P0):
    kfs = []
    for i in range(F.shape[0]):
        kf = KalmanFilter(dim_x=F.shape[1], dim_z=H.shape[1])
        kf.F, kf.Q, kf.H, kf.R = F[i], Q[i], H[i], R[i]
        kf.x = x0.copy()[:, None]
        kf.P = P0.copy()
        kfs.append(kf)
    return kfs


# n = 15: the bank pads its states to 16 (linear._padded_width). Two measurements observe 15
# random-walk states poorly: with the coupling 0.05 (0.01) their covariances reach a condition
# number of 5e7 (5e6) in 300 steps, and two evaluation orders of the same filter (padded or not,
# ours or FilterPy's) drift 6e-5 (3e-9) apart; at 0.001 it is 5e3 and they agree to 1e-12
@pytest.mark.parametrize("n, coupling", [(6, 0.05), (15, 0.001)])
def test_matches_filterpy_predict_update_joseph(n, coupling):
    F, Q, H, R = _system(n=n, coupling=coupling)
    N, n = F.shape[:2]
    x0, P0 = np.zeros(n), np.eye(n) * 50.0
    bank = LinearFilterBank([f"k{i}" for i in range(N)], F, Q, H, R, x0, P0)
    kfs = _filterpy(F, Q, H, R, x0, P0)
    rng = np.random.default_rng(7)
    for k in range(300):
        z = rng.standard_normal(H.shape[1]) * 3.0
        rec = bank.step(z, t=float(k), seq=k)
        for i, kf in enumerate(kfs):
            kf.predict()
            y_prior = z - H[i] @ kf.x[:, 0]
            S_prior = H[i] @ kf.P @ H[i].T + R[i]
            np.testing.assert_allclose(rec.residual[i], y_prior, rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(rec.S[i], S_prior, rtol=1e-10, atol=1e-10)
            assert rec.chi2[i] == pytest.approx(float(y_prior @ np.linalg.solve(S_prior, y_prior)), rel=1e-9)
            kf.update(z)
            np.testing.assert_allclose(bank.x[i], kf.x[:, 0], rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(bank.P[i], kf.P, rtol=1e-10, atol=1e-10)
    assert rec.processed.all() and rec.active.all()


@pytest.mark.parametrize("n", [6, 9])
def test_update_without_predict_matches_filterpy_update(n):
    F, Q, H, R = _system(N=2, n=n)
    n = F.shape[1]
    bank = LinearFilterBank(["a", "b"], F, Q, H, R, np.ones(n), np.eye(n) * 4.0)
    kfs = _filterpy(F, Q, H, R, np.ones(n), np.eye(n) * 4.0)
    z = np.array([0.3, -1.2])
    bank.update(z)
    for i, kf in enumerate(kfs):
        kf.update(z)
        np.testing.assert_allclose(bank.x[i], kf.x[:, 0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(bank.P[i], kf.P, rtol=1e-12, atol=1e-12)


def test_filters_that_do_not_process_keep_their_prediction_but_report_statistics():
    F, Q, H, R = _system(N=3)
    n = F.shape[1]
    bank = LinearFilterBank(["a", "b", "c"], F, Q, H, R, np.zeros(n), np.eye(n),
                            processes=[("generic-linear",), (), ("generic-linear",)])
    kfs = _filterpy(F, Q, H, R, np.zeros(n), np.eye(n))
    rec = bank.step(np.array([1.0, 2.0]))
    kfs[1].predict()
    np.testing.assert_allclose(bank.x[1], kfs[1].x[:, 0], atol=1e-14)
    np.testing.assert_allclose(bank.P[1], kfs[1].P, atol=1e-14)
    assert rec.processed.tolist() == [True, False, True]
    assert np.isfinite(rec.chi2).all()


def test_disabled_filter_is_frozen_and_marked_inactive():
    F, Q, H, R = _system(N=3)
    n = F.shape[1]
    bank = LinearFilterBank(["a", "b", "c"], F, Q, H, R, np.zeros(n), np.eye(n))
    bank.set_enabled("b", False)
    x_b, P_b = bank.x[1].copy(), bank.P[1].copy()
    rec = bank.step(np.array([1.0, 2.0]))
    assert rec.active.tolist() == [True, False, True]
    assert not rec.processed[1] and np.isnan(rec.chi2[1])
    np.testing.assert_array_equal(bank.x[1], x_b)
    np.testing.assert_array_equal(bank.P[1], P_b)
    bank.set_enabled("b", True)
    assert bank.step(np.array([1.0, 2.0])).processed.all()


def test_gate_edits_outliers():
    F, Q, H, R = _system(N=2)
    n = F.shape[1]
    bank = LinearFilterBank(["a", "b"], F, Q, H, R, np.zeros(n), np.eye(n), gate_chi2=[None, 9.0])
    rec = bank.step(np.array([1e4, -1e4]))
    assert rec.processed.tolist() == [True, False]


def test_bad_input_is_rejected_before_touching_state_and_counted():
    F, Q, H, R = _system(N=2)
    n = F.shape[1]
    bank = LinearFilterBank(["a", "b"], F, Q, H, R, np.zeros(n), np.eye(n))
    x, P = bank.x.copy(), bank.P.copy()
    with pytest.raises(MeasurementRejected) as e1:
        bank.step(np.array([np.nan, 1.0]))
    with pytest.raises(MeasurementRejected) as e2:
        bank.step(np.array([1.0, 2.0, 3.0]))
    with pytest.raises(MeasurementRejected) as e3:
        bank.process(Measurement(seq=0, t_s=0.0, timestamp=Stamp(0, 0), kind="range", source="DSS-14",
                                 value=(1.0,), sigma=(1.0,)))
    assert (e1.value.reason, e2.value.reason, e3.value.reason) == ("non_finite", "bad_dimension", "unknown_kind")
    assert bank.rejected == {"non_finite": 1, "bad_dimension": 1, "unknown_kind": 1}
    np.testing.assert_array_equal(bank.x, x)
    np.testing.assert_array_equal(bank.P, P)
    rec = bank.process(Measurement(seq=5, t_s=1.0, timestamp=Stamp(0, 0), kind="generic-linear", source="track",
                                   value=(0.5, 0.1), sigma=(1.0, 1.0)))
    assert rec.seq == 5 and rec.kind == "generic-linear"


def test_measurement_noise_must_be_symmetric_positive_definite():
    """S = HP̄Hᵀ + R is inverted without checks: an R that could make it singular is refused at
    the door, at construction and when it is changed, and the bank is left as it was."""
    F, Q, H, R = _system(N=2)
    n = F.shape[1]
    for bad in (np.zeros((2, 2)), np.diag([1.0, -1.0]), np.array([[1.0, 0.5], [0.0, 1.0]])):
        with pytest.raises(ValueError, match="R must be"):
            LinearFilterBank(["a", "b"], F, Q, H, bad, np.zeros(n), np.eye(n))
    bank = LinearFilterBank(["a", "b"], F, Q, H, R, np.zeros(n), np.eye(n))
    before = bank.R.copy()
    with pytest.raises(ValueError, match="positive definite"):
        bank.set_measurement_noise("a", np.zeros((2, 2)))
    np.testing.assert_array_equal(bank.R, before)
    # even with a zero prior (S = R) the step is well defined
    zero = LinearFilterBank(["a", "b"], F, np.zeros_like(Q), H, R, np.zeros(n), np.zeros((n, n)))
    rec = zero.step(np.array([1.0, -1.0]))
    assert np.all(np.isfinite(rec.chi2)) and np.all(np.isfinite(zero.P))


def test_weighted_and_best_estimates():
    F, Q, H, R = _system(N=2)
    n = F.shape[1]
    bank = LinearFilterBank(["a", "b"], F, Q, H, R, np.zeros(n), np.eye(n))
    bank.step(np.array([1.0, 2.0]))
    est = bank.estimates(weights=[0.25, 0.75])
    x_opt = 0.25 * bank.x[0] + 0.75 * bank.x[1]
    np.testing.assert_allclose(est["combined"].x, x_opt)
    d0, d1 = bank.x[0] - x_opt, bank.x[1] - x_opt
    P_mix = 0.25 * (bank.P[0] + np.outer(d0, d0)) + 0.75 * (bank.P[1] + np.outer(d1, d1))
    np.testing.assert_allclose(est["combined"].P, P_mix, atol=1e-12)
    np.testing.assert_array_equal(est["best"].x, bank.x[1])


def _exact_joseph(F, Q, H, R, P0):
    """P⁺ of one predict and update, in exact rational arithmetic from the float inputs."""
    def q(a):
        return [[Fraction(float(v)) for v in row] for row in np.atleast_2d(a)]

    def mul(*ms):
        out = ms[0]
        for b in ms[1:]:
            out = [[sum(x * y for x, y in zip(row, col)) for col in zip(*b)] for row in out]
        return out

    def add(a, b, sign=1):
        return [[x + sign * y for x, y in zip(r, s)] for r, s in zip(a, b)]

    def t(a):
        return [list(c) for c in zip(*a)]

    F, Q, H, R = q(F), q(Q), q(H), q(R)
    Pb = add(mul(F, q(P0), t(F)), Q)
    (a, b), (c, d) = add(mul(H, Pb, t(H)), R)
    det = a * d - b * c
    K = mul(Pb, t(H), [[d / det, -b / det], [-c / det, a / det]])
    A = add([[Fraction(int(i == j)) for j in range(len(F))] for i in range(len(F))], mul(K, H), -1)
    return np.array(add(mul(A, Pb, t(A)), mul(K, R, t(K))), dtype=float)


def test_covariance_stays_spd_over_50000_updates():
    """Every covariance of the bank is symmetric positive definite after every one of 50,000
    updates, with strong measurements (R ≪ P) that break the conventional update; the first
    update, where R is 1e-14 of the prior, is accurate, not just positive definite."""
    rng = np.random.default_rng(11)
    n, m, N = 3, 2, 3
    F = np.array([[1.0, 1.0, 0.5], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]])
    Q = np.diag([1e-12, 1e-12, 1e-10])
    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    R = np.array([np.diag([1e-8, 1e-8]), np.diag([1.0, 1e-6]), np.diag([1e2, 1e2])])
    P0 = np.diag([1e6, 1e4, 1e2])
    bank = LinearFilterBank(["x", "y", "z"], F, Q, H, R, np.zeros(n), P0)
    truth = np.zeros(n)
    for k in range(50_000):
        truth = F @ truth + rng.normal(0.0, 1e-6, n)
        bank.step(H @ truth + rng.normal(0.0, 1e-4, m))
        P = bank.P
        if k == 0:
            # the conventional form is off by 1.3e-2 here; each entry against √(PᵢᵢPⱼⱼ)
            exact = _exact_joseph(F, Q, H, R[0], P0)
            scale = np.sqrt(np.outer(np.diag(exact), np.diag(exact)))
            assert np.max(np.abs(P[0] - exact) / scale) <= 1e-12
        assert np.max(np.abs(P - P.transpose(0, 2, 1))) <= 1e-12 * np.max(np.abs(P))
        np.linalg.cholesky(P)  # raises if any covariance lost positive definiteness
    assert all(is_spd(P) for P in bank.P)

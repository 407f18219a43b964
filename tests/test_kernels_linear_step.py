"""The compiled linear-bank step against the textbook Kalman filter written out per filter in
numpy (predict; K = P̄Hᵀ(HP̄Hᵀ + R)⁻¹; Joseph P⁺ = (I − KH)P̄(I − KH)ᵀ + KRKᵀ), on random
banks with disabled filters, filters that do not process, gates, and m = 1, 2, 3."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.kernels.linear_step import linear_step


def _bank(rng: np.random.Generator, N: int, n: int, m: int):
    F = np.eye(n)[None] + 0.1 * rng.normal(size=(N, n, n))
    Aq = rng.normal(size=(N, n, n)) * 0.1
    Q = Aq @ Aq.transpose(0, 2, 1)
    H = rng.normal(size=(N, m, n))
    Ar = rng.normal(size=(N, m, m))
    R = Ar @ Ar.transpose(0, 2, 1) + np.eye(m)
    x = rng.normal(size=(N, n))
    A = rng.normal(size=(N, n, n))
    P = A @ A.transpose(0, 2, 1) + np.eye(n)
    return F, Q, H, R, x, P


def _textbook(F, Q, H, R, x, P, z, predict):
    if predict:
        x, P = F @ x, F @ P @ F.T + Q
    S = H @ P @ H.T + R
    residual = z - H @ x
    K = P @ H.T @ np.linalg.inv(S)
    X = np.eye(len(x)) - K @ H
    return x, P, residual, S, float(residual @ np.linalg.solve(S, residual)), x + K @ residual, \
        X @ P @ X.T + K @ R @ K.T


@pytest.mark.parametrize("m", [1, 2, 3])
@pytest.mark.parametrize("predict", [True, False])
@pytest.mark.parametrize("seed", range(4))
def test_linear_step_matches_the_textbook_filter(m, predict, seed):
    rng = np.random.default_rng(1000 * m + 10 * seed + predict)
    N, n = 5, int(rng.choice([1, 2, 6, 15]))
    F, Q, H, R, x0, P0 = _bank(rng, N, n, m)
    z = rng.normal(size=m) * 3.0
    active = np.array([True, True, True, True, False])
    does = np.array([True, True, False, True, True])
    gate = np.array([np.inf, np.inf, np.inf, 0.0, np.inf])  # filter 3 is edited out (χ² > 0)
    x, P = x0.copy(), P0.copy()
    residual, S, chi2 = np.empty((N, m)), np.empty((N, m, m)), np.empty(N)
    processed = np.empty(N, dtype=bool)
    linear_step(F, np.ascontiguousarray(F.transpose(0, 2, 1)), Q, H, R, x, P, z, active, does, gate, predict,
                residual, S, chi2, processed)
    assert processed.tolist() == [True, True, False, False, False]
    for i in range(4):
        xb, Pb, res_ref, S_ref, chi2_ref, x_up, P_up = _textbook(F[i], Q[i], H[i], R[i], x0[i], P0[i], z, predict)
        np.testing.assert_allclose(residual[i], res_ref, rtol=1e-10, atol=1e-10 * np.abs(z).max())
        np.testing.assert_allclose(S[i], S_ref, rtol=1e-10)
        assert chi2[i] == pytest.approx(chi2_ref, rel=1e-9)
        x_ref, P_ref = (x_up, P_up) if processed[i] else (xb, Pb)
        scale = np.sqrt(np.outer(np.diag(P_ref), np.diag(P_ref)))
        np.testing.assert_allclose(x[i], x_ref, rtol=1e-9, atol=1e-9 * np.sqrt(np.diag(P_ref)).max())
        assert np.max(np.abs(P[i] - P_ref) / scale) <= 1e-10
        if processed[i]:
            assert np.array_equal(P[i], P[i].T)  # made exactly symmetric
    # the disabled filter is untouched and reports nothing
    assert np.array_equal(x[4], x0[4]) and np.array_equal(P[4], P0[4])
    assert np.isnan(residual[4]).all() and np.isnan(S[4]).all() and np.isnan(chi2[4])


def test_linear_step_refuses_arrays_of_the_wrong_type():
    rng = np.random.default_rng(0)
    F, Q, H, R, x, P = _bank(rng, 2, 3, 1)
    out = (np.empty((2, 1)), np.empty((2, 1, 1)), np.empty(2), np.empty(2, dtype=bool))
    flags = (np.ones(2, dtype=bool), np.ones(2, dtype=bool), np.full(2, np.inf))
    with pytest.raises(TypeError):  # explicit signature: no silent recompilation for float32
        linear_step(F.astype(np.float32), F, Q, H, R, x, P, np.zeros(1), *flags, True, *out)

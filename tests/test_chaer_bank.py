"""The Chaer et al. 1997 §V tracking scenario generator and the small Kalman filter bank the gating tests
run on it (checked here against FilterPy, an independent implementation)."""

from __future__ import annotations

import ast
import pathlib

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from fsw.filters.record import BankRecord
from sim.scenarios import chaer_tracking as ct


def run_bank(z: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linear KFs of Chaer et al. 1997 eqs. 2–6, one per row α = [q1 q2 r1 r2], vectorised across filters.

    Returns pre-update residuals (K, L, 2) and innovation covariances (K, L, 2, 2); measurement 0
    is processed at the a-priori x̂₀⁻, P₀⁻ (Chaer et al. 1997 §V)."""
    alpha = np.asarray(alpha, dtype=float)
    n_f, k_total = len(alpha), len(z)
    F = np.asarray(ct.TRANSITION)
    H = np.asarray(ct.MEASUREMENT_MATRIX)
    x = np.tile(np.asarray(ct.FILTER_INITIAL_STATE, dtype=float), (n_f, 1))
    P = np.tile(np.asarray(ct.FILTER_INITIAL_COVARIANCE, dtype=float), (n_f, 1, 1))
    Q = np.zeros((n_f, 2, 2))
    R = np.zeros((n_f, 2, 2))
    Q[:, 0, 0], Q[:, 1, 1], R[:, 0, 0], R[:, 1, 1] = alpha.T
    res = np.empty((k_total, n_f, 2))
    S = np.empty((k_total, n_f, 2, 2))
    eye = np.eye(2)
    for k in range(k_total):
        if k > 0:
            x = x @ F.T
            P = F @ P @ F.T + Q
        r = z[k] - x @ H.T
        Sk = H @ P @ H.T + R
        gain = P @ H.T @ np.linalg.inv(Sk)
        x = x + np.einsum("lij,lj->li", gain, r)
        ikh = eye - gain @ H
        P = ikh @ P @ ikh.transpose(0, 2, 1) + gain @ R @ gain.transpose(0, 2, 1)
        res[k], S[k] = r, Sk
    return res, S


def chi_square(res: np.ndarray, S: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", res, np.linalg.solve(S, res[..., None])[..., 0])


def gaussian_loglik(res: np.ndarray, S: np.ndarray) -> np.ndarray:
    n = res.shape[-1]
    return -0.5 * (chi_square(res, S) + np.linalg.slogdet(S)[1] + n * np.log(2 * np.pi))


def make_records(res: np.ndarray, S: np.ndarray, t: np.ndarray, names=None, kind: str = "generic-linear"):
    """One BankRecord per measurement (every filter processes every measurement)."""
    n_f = res.shape[1]
    names = tuple(names or (f"KF{i + 1}" for i in range(n_f)))
    chi2 = chi_square(res, S)
    processed = np.ones(n_f, dtype=bool)
    return [
        BankRecord(t=float(t[k]), seq=k, kind=kind, filters=names, residual=res[k], S=S[k],
                   chi2=chi2[k], processed=processed)
        for k in range(len(t))
    ]


def test_generator_shapes_and_reproducibility():
    a = ct.experiment_3(np.random.default_rng(7))
    b = ct.experiment_3(np.random.default_rng(7))
    assert a.z.shape == (500, 2) and a.x.shape == (500, 2) and a.t.shape == (500,)
    np.testing.assert_array_equal(a.z, b.z)
    np.testing.assert_array_equal(np.bincount(a.segment), [100] * 5)
    np.testing.assert_array_equal(a.x[0], [0.0, 100.0])
    np.testing.assert_array_equal(a.t[:3], [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(a.alpha, np.asarray(ct.TABLE_III))


def test_generator_noise_statistics_per_segment():
    run = ct.generate(ct.TABLE_III, 20000, np.random.default_rng(1))
    F = np.asarray(ct.TRANSITION)
    w = run.x[1:] - run.x[:-1] @ F.T  # process noise that produced x_k
    v = run.z - run.x
    for s, (q1, q2, r1, r2) in enumerate(ct.TABLE_III):
        in_seg = run.segment == s
        ws = w[in_seg[1:] & in_seg[:-1]]
        vs = v[in_seg]
        np.testing.assert_allclose(ws.var(axis=0), [q1, q2], rtol=0.05)
        np.testing.assert_allclose(vs.var(axis=0), [r1, r2], rtol=0.05)
        assert abs(np.corrcoef(vs.T)[0, 1]) < 0.05


def test_paper_tables():
    assert ct.bank_parameters(1)[2].tolist() == [16.0, 16.0, 16.0, 16.0] == list(ct.TABLE_I_TRUTH)
    assert ct.bank_parameters(2)[2].tolist() == [12.0, 12.0, 20.0, 20.0]
    assert ct.bank_parameters(2)[4].tolist() == [5.0, 20.0, 25.0, 10.0]
    assert list(ct.TABLE_II_TRUTH) == [16.0] * 4
    assert ct.bank_parameters(3)[3].tolist() == [5.0, 25.0, 2.0, 25.0]
    assert ct.bank_parameters(3)[4].tolist() == [1.0, 1.0, 2.0, 50.0]
    assert ct.bank_parameters(4)[1].tolist() == [0.0, 0.0, 5.0, 5.0]  # Table IV
    with pytest.raises(ValueError):
        ct.bank_parameters(5)
    with pytest.raises(ValueError):
        ct.generate([(1.0, 1.0, 1.0)], 10, np.random.default_rng(0))


def test_scenario_imports_numpy_only():
    tree = ast.parse(pathlib.Path(ct.__file__).read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add((node.module or "").split(".")[0])
    assert imported <= {"numpy", "typing", "__future__"}


def test_bank_matches_filterpy():
    run = ct.experiment_3(np.random.default_rng(3))
    alpha = ct.bank_parameters(3)
    res, S = run_bank(run.z, alpha)
    for i, (q1, q2, r1, r2) in enumerate(alpha):
        kf = KalmanFilter(dim_x=2, dim_z=2)
        kf.F = np.asarray(ct.TRANSITION)
        kf.H = np.asarray(ct.MEASUREMENT_MATRIX)
        kf.Q = np.diag([q1, q2])
        kf.R = np.diag([r1, r2])
        kf.x = np.asarray(ct.FILTER_INITIAL_STATE, dtype=float).reshape(2, 1)
        kf.P = np.asarray(ct.FILTER_INITIAL_COVARIANCE, dtype=float)
        for k in range(len(run.t)):
            if k > 0:
                kf.predict()
            kf.update(run.z[k].reshape(2, 1))
            np.testing.assert_allclose(res[k, i], kf.y.ravel(), rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(S[k, i], kf.S, rtol=1e-9, atol=1e-9)


def expected_log_likelihood(filt, truth) -> float:
    """E[ln N(r; 0, S)] per measurement for a steady-state KF with parameters ``filt`` on data
    with noise ``truth`` (α = [q1 q2 r1 r2]): S from the discrete Riccati equation, the actual
    innovation covariance C from the Lyapunov equation of the filter's error dynamics."""
    from scipy.linalg import solve_discrete_are, solve_discrete_lyapunov

    F, H = np.asarray(ct.TRANSITION), np.asarray(ct.MEASUREMENT_MATRIX)
    P = solve_discrete_are(F.T, H.T, np.diag(filt[:2]), np.diag(filt[2:]))
    S = H @ P @ H.T + np.diag(filt[2:])
    K = P @ H.T @ np.linalg.inv(S)
    A = F @ (np.eye(2) - K @ H)
    E = solve_discrete_lyapunov(A, F @ K @ np.diag(truth[2:]) @ K.T @ F.T + np.diag(truth[:2]))
    C = H @ E @ H.T + np.diag(truth[2:])
    return float(-0.5 * (np.trace(np.linalg.solve(S, C)) + np.linalg.slogdet(S)[1] + 2 * np.log(2 * np.pi)))


def test_separations_between_filters_analytic_and_monte_carlo():
    # The numbers the scenario docstring quotes: how far (nat per measurement) the matching filter
    # is ahead of the others, from the steady-state equations, checked by simulation.
    table3 = np.asarray(ct.TABLE_III)
    ell = np.array([[expected_log_likelihood(f, t) for f in table3] for t in table3])  # [truth, filter]
    gaps = [np.sort(row)[-1] - np.sort(row)[-2] for row in ell]
    assert [int(np.argmax(row)) for row in ell] == [0, 1, 2, 3, 4]
    np.testing.assert_allclose(gaps, [1.055, 0.331, 0.477, 0.307, 0.566], atol=2e-3)
    assert ell[1, 1] - ell[1, 0] == pytest.approx(5.67, abs=0.01)
    table1 = np.asarray(ct.TABLE_I)
    ell1 = [expected_log_likelihood(f, np.asarray(ct.TABLE_I_TRUTH)) for f in table1]
    ell2 = [expected_log_likelihood(f, np.asarray(ct.TABLE_II_TRUTH)) for f in np.asarray(ct.TABLE_II)]
    assert np.argmax(ell1) == 2 and np.argmax(ell2) == 2
    assert ell1[2] - ell1[3] == pytest.approx(0.033, abs=2e-3)
    assert ell2[2] - ell2[3] == pytest.approx(0.023, abs=2e-3)
    assert max(ell1[2] - ell1[i] for i in (1, 3, 4)) < 0.06
    # Monte Carlo: the bank's mean log-likelihood on long stationary runs (start-up dropped).
    for s in (0, 2, 4):
        run = ct.generate([table3[s]], 20000, np.random.default_rng(10 + s))
        res, S = run_bank(run.z, table3)
        mc = gaussian_loglik(res, S)[100:].mean(axis=0)
        # A badly mismatched filter has a heavy-tailed chi-square: relative tolerance for it.
        np.testing.assert_allclose(mc, ell[s], rtol=0.01, atol=0.03)
        np.testing.assert_allclose(mc - mc[s], ell[s] - ell[s, s], rtol=0.01, atol=0.03)


def test_switch_delays_rules():
    W = np.full((300, 3), 0.1)
    W[:100, 0] = 0.8
    W[100:104, 0] = [0.79, 0.75, 0.7, 0.2]      # falls below 0.9 × 0.8 at the 3rd measurement
    W[104:200, 1] = 0.8                          # filter 1 on top from the 5th
    W[200:, 1] = 0.8                             # filter 2 never on top in the last segment
    W[100:104, 1] = [0.1, 0.1, 0.1, 0.7]
    np.testing.assert_array_equal(ct.switch_delays(W, rule="top"), [4, 101])
    np.testing.assert_array_equal(ct.switch_delays(W, rule="onset"), [3, 101])
    with pytest.raises(ValueError):
        ct.switch_delays(W[:150])
    with pytest.raises(ValueError):
        ct.switch_delays(W, rule="bogus")

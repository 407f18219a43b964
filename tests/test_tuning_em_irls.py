"""EM with IRLS for the hierarchical gating network (Chaer et al. 1998 §IV, eqs. 17–23): the E step
against a direct evaluation, IRLS against a generic optimiser, monotone likelihood, and the EM
fixed point against a direct maximisation of eq. 17 (scipy) on a small case."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from ground.tuning import em_irls as em


def mixture_case(N: int = 400, seed: int = 0) -> tuple[list[np.ndarray], np.ndarray]:
    """Scalar z from a two-level mixture whose top-level choice depends on an input x: bank 1 holds
    unit Gaussians at −2 and 0, bank 2 at 1, 2.5 and 4; ln f(z | α_{j|i}) are their log-densities."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, N)
    phi = np.column_stack([np.ones(N), x])
    means = [np.array([-2.0, 0.0]), np.array([1.0, 2.5, 4.0])]
    bank = (rng.random(N) < 1.0 / (1.0 + np.exp(-2.0 * x))).astype(int)
    z = np.array([means[b][rng.integers(len(means[b]))] for b in bank]) + rng.standard_normal(N)
    return [-0.5 * (z[:, None] - m) ** 2 - 0.5 * np.log(2 * np.pi) for m in means], phi


def _free(theta: em.Hierarchy) -> list[np.ndarray]:
    return [theta.top, *theta.banks]


def _unpack(v: np.ndarray, like: em.Hierarchy) -> em.Hierarchy:
    t = like.copy()
    i = 0
    for arr in _free(t):
        n = (arr.shape[0] - 1) * arr.shape[1]
        arr[:-1] = v[i:i + n].reshape(arr.shape[0] - 1, arr.shape[1])
        i += n
    return t


def test_e_step_matches_the_direct_formulas():
    log_f, phi = mixture_case(30)
    rng = np.random.default_rng(1)
    theta = em.Hierarchy(rng.standard_normal((2, 2)), [rng.standard_normal((2, 2)), rng.standard_normal((3, 2))])
    h_top, h_in = em.posteriors(theta, log_f, phi)
    for k in range(30):
        gi = np.exp(theta.top @ phi[k]) / np.exp(theta.top @ phi[k]).sum()
        gj = [np.exp(b @ phi[k]) / np.exp(b @ phi[k]).sum() for b in theta.banks]
        joint = [gi[i] * gj[i] * np.exp(log_f[i][k]) for i in range(2)]  # eq. 18's numerator
        total = sum(j.sum() for j in joint)
        for i in range(2):
            assert h_top[k, i] == pytest.approx(joint[i].sum() / total, rel=1e-12)  # eq. 9
            np.testing.assert_allclose(h_in[i][k], joint[i] / joint[i].sum(), rtol=1e-12)  # eq. 10
    direct = 0.0
    for k in range(30):
        gi = np.exp(theta.top @ phi[k]) / np.exp(theta.top @ phi[k]).sum()
        direct += np.log(sum(gi[i] * np.sum(np.exp(b @ phi[k]) / np.exp(b @ phi[k]).sum() * np.exp(log_f[i][k]))
                             for i, b in enumerate(theta.banks)))  # eq. 17, term by term
    assert em.log_likelihood(theta, log_f, phi) == pytest.approx(direct, rel=1e-12)


def test_irls_solves_the_weighted_m_step():
    rng = np.random.default_rng(2)
    N, C, d = 200, 3, 2
    phi = np.column_stack([np.ones(N), rng.standard_normal(N)])
    h = rng.dirichlet(np.ones(C), N)
    w = rng.random(N)
    A = em.irls(np.zeros((C, d)), phi, h, w)
    assert np.all(A[-1] == 0.0)
    res = minimize(lambda v: -em.m_objective(np.vstack([v.reshape(C - 1, d), np.zeros(d)]), phi, h, w),
                   np.zeros((C - 1) * d), method="BFGS", options={"gtol": 1e-10})
    np.testing.assert_allclose(A[:-1].ravel(), res.x, atol=1e-5)
    assert em.m_objective(A, phi, h, w) >= -res.fun - 1e-9


def test_em_likelihood_is_monotone_and_the_fixed_point_is_the_direct_maximum():
    log_f, phi = mixture_case()
    r = em.run_em(log_f, phi, epsilon=1e-8, max_iterations=5000)
    ll = np.array(r.log_likelihood)
    assert r.converged and r.iterations > 5
    assert np.all(np.diff(ll) >= -1e-9 * abs(ll[-1]))
    assert ll[-1] > ll[0] + 10.0
    t0 = em.initial(2, [2, 3], 2)
    n_free = sum((a.shape[0] - 1) * a.shape[1] for a in _free(t0))
    res = minimize(lambda v: -em.log_likelihood(_unpack(v, t0), log_f, phi), np.zeros(n_free), method="BFGS",
                   options={"gtol": 1e-8})
    assert ll[-1] == pytest.approx(-res.fun, abs=1e-6)
    np.testing.assert_allclose(r.theta.vector(), _unpack(res.x, t0).vector(), atol=1e-4)


def test_constant_input_gives_the_mixing_proportions():
    """With φ = [1] (the FSW gates' input) and one bank, the EM fixed point is the classic mixture
    proportion estimate: g_j = mean_k h_{j,k} at the fixed point."""
    log_f, _ = mixture_case(500, seed=3)
    single = [np.concatenate(log_f, axis=1)]
    r = em.run_em(single, epsilon=1e-10, max_iterations=2000)
    _, h_in = em.posteriors(r.theta, single, np.ones((500, 1)))
    _, g_in = em.weights(r.theta, np.ones((500, 1)))
    np.testing.assert_allclose(g_in[0][0], h_in[0].mean(axis=0), atol=1e-6)


def test_max_iterations_stops_unconverged():
    log_f, phi = mixture_case(50)
    r = em.run_em(log_f, phi, max_iterations=3)
    assert len(r.log_likelihood) == 4 and not r.converged


@pytest.mark.parametrize("bad", [[], [np.full((3, 2), np.nan)], [np.zeros((3, 2)), np.zeros((4, 2))]])
def test_bad_input_is_refused(bad):
    with pytest.raises(ValueError):
        em.run_em(bad)


def test_switch_is_where_the_lead_changes_for_good():
    from ground.tuning.recorded_residuals import switch_index

    top = np.array([[0.6, 0.4]] * 30 + [[0.3, 0.7]] * 5 + [[0.6, 0.4]] * 5 + [[0.2, 0.8]] * 60)
    assert switch_index(top) == 40
    assert switch_index(np.array([[0.6, 0.4]] * 50)) is None
    assert switch_index(np.array([[0.6, 0.4]] * 3 + [[0.2, 0.8]] * 97)) is None  # start-up, not a switch


def test_cli_em_refuses_a_missing_recording(tmp_path, capsys):
    from tools.cli import main

    assert main(["tune", "em", str(tmp_path / "none.mcap"), "--out", str(tmp_path / "em")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


@pytest.mark.slow
def test_pathfinder_cruise_em_on_a_recording(tmp_path, capsys):
    """Chaer et al. 1998 §V with EM: on a recorded `pathfinder-cruise` run (flown in process, recorded with
    its configuration), `navbank tune em` re-runs the recording, splits at the online switch, and EM's
    likelihood rises monotonically in both segments to top-level weights favouring bank 2 before
    the switch and bank 3 after it; bank 3 picks KF 2|3 after it."""
    import json

    from tools.cli import main
    from tools.validation.chaer1998_em import cruise_recording

    rec = cruise_recording(tmp_path / "cruise.mcap", seed=1)
    assert main(["tune", "em", str(rec), "--out", str(tmp_path / "em")]) == 0
    out = json.loads((tmp_path / "em" / "em.json").read_text())
    assert out["split"] is not None and len(out["segments"]) == 2
    before, after = out["segments"]
    for seg in (before, after):
        ll = np.array(seg["log_likelihood"])
        assert seg["converged"] and np.all(np.diff(ll) >= -1e-9 * abs(ll[-1]))
    assert max(before["top"], key=before["top"].get) == "bank2"
    assert max(after["top"], key=after["top"].get) == "bank3"
    assert max(after["in_bank"]["bank3"], key=after["in_bank"]["bank3"].get) == "kf2_3"
    assert (tmp_path / "em" / "em-weights.png").stat().st_size > 0

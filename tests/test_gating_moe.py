"""Mixture-of-experts gating network on the seed 003 §V tracking experiments, and its learning
rule against a numerical gradient of the log-likelihood (seed 003 eq. 15)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp

from fsw.filters.record import BankRecord
from fsw.gating import make_network
from fsw.gating.moe import MoeNetwork, MoeParams
from sim.scenarios import chaer_tracking as ct
from test_chaer_bank import gaussian_loglik, make_records, run_bank

NAMES = tuple(f"KF{i}" for i in range(1, 6))


def weights_history(network: str, run, alpha, **params) -> np.ndarray:
    res, S = run_bank(run.z, alpha)
    net = make_network(network, NAMES, params or None)
    return np.array([net.update(r).weights for r in make_records(res, S, run.t, NAMES)])


def log_likelihood_of_gate(a: np.ndarray, phi: np.ndarray, loglik: np.ndarray) -> float:
    """Seed 003 eq. 15/17: l = ln Σ_i f_i exp(u_i) − ln Σ_i exp(u_i), u_i = a_iᵀφ."""
    u = a @ phi
    return float(logsumexp(loglik + u) - logsumexp(u))


def test_update_is_gradient_ascent_on_eq15():
    rng = np.random.default_rng(0)
    a0 = rng.standard_normal((4, 3))
    phi = np.array([1.0, 0.3, -0.7])
    res = rng.standard_normal((4, 2))
    S = np.tile(np.eye(2), (4, 1, 1)) * rng.uniform(0.5, 3.0, (4, 1, 1))
    chi2 = np.einsum("ij,ij->i", res, np.linalg.solve(S, res[..., None])[..., 0])
    rec = BankRecord(t=0.0, seq=0, kind="range", filters=("a", "b", "c", "d"), residual=res, S=S,
                     chi2=chi2, processed=np.ones(4, bool))
    eta = 0.37
    net = MoeNetwork(rec.filters, MoeParams(eta=eta), feature_map=lambda r: phi, feature_dim=3)
    net._a = a0.copy()
    net.update(rec)
    loglik = gaussian_loglik(res, S)
    grad = np.zeros_like(a0)
    h = 1e-6
    for i in range(4):
        for d in range(3):
            ap, am = a0.copy(), a0.copy()
            ap[i, d] += h
            am[i, d] -= h
            grad[i, d] = (log_likelihood_of_gate(ap, phi, loglik) - log_likelihood_of_gate(am, phi, loglik)) / (2 * h)
    np.testing.assert_allclose(net.cell_weights - a0, eta * grad, atol=1e-8)
    g = np.exp(a0 @ phi - logsumexp(a0 @ phi))
    np.testing.assert_allclose(net.weights, np.exp(net.cell_weights @ phi - logsumexp(net.cell_weights @ phi)))
    assert not np.allclose(net.weights, g)


@pytest.mark.parametrize("experiment", [1, 2])
def test_experiments_1_and_2_select_kf3(experiment):
    # Table I/II filters KF 2, 4, 5 have innovation statistics within ~0.05 nat per measurement of
    # KF 3's, so the selection needs several hundred measurements at η = 1.
    finals, top_share, at300 = [], [], []
    for seed in range(5):
        run = (ct.experiment_1 if experiment == 1 else ct.experiment_2)(np.random.default_rng(seed), length=1500)
        W = weights_history("moe", run, ct.bank_parameters(experiment), eta=1.0)
        slow = weights_history("moe", run, ct.bank_parameters(experiment), eta=0.1)
        finals.append(W[-1])
        top_share.append(np.mean(np.argmax(W[1000:], axis=1) == 2))
        at300.append((W[299, 2], slow[299, 2]))
    finals = np.array(finals)
    print(f"experiment {experiment}: final weights (mean of 5 runs) {np.round(finals.mean(axis=0), 3)}; "
          f"share of the last 500 measurements with KF3 on top {np.round(top_share, 2)}; "
          f"KF3 weight at 300 (eta=1, eta=0.1) {np.round(at300, 3).tolist()}")
    assert np.argmax(finals.mean(axis=0)) == 2
    # Experiment 2's KF 4 is within 0.02 nat/measurement of KF 3: it wins some runs.
    assert np.sum(np.argmax(finals, axis=1) == 2) >= (5 if experiment == 1 else 3)
    assert np.mean(top_share) >= (0.9 if experiment == 1 else 0.5)
    if experiment == 1:
        assert finals[:, 2].mean() > 0.7
    # A larger learning rate converges faster (seed 003 Figs. 6–7).
    assert all(fast > slow for fast, slow in at300)


def switch_delays(W: np.ndarray, seg_len: int = 100) -> list[int]:
    """For each regime change, measurements until the matching filter first has the top weight
    (101 = not within the segment)."""
    out = []
    for s in range(1, 5):
        hit = np.flatnonzero(np.argmax(W[s * seg_len:(s + 1) * seg_len], axis=1) == s)
        out.append(int(hit[0]) + 1 if hit.size else seg_len + 1)
    return out


def test_experiment_3_switching_moe_vs_magill():
    moe, magill = [], []
    for seed in range(10):
        run = ct.experiment_3(np.random.default_rng(seed))
        res, S = run_bank(run.z, ct.bank_parameters(3))
        recs = make_records(res, S, run.t, NAMES)
        m = make_network("moe", NAMES, {"eta": 1.0})
        g = make_network("magill", NAMES)
        Wm = np.array([m.update(r).weights for r in recs])
        Wg = np.array([g.update(r).weights for r in recs])
        # Within segment 1 both settle on KF 1.
        assert np.all(np.argmax(Wm[20:100], axis=1) == 0) and np.all(np.argmax(Wg[20:100], axis=1) == 0)
        moe.append(switch_delays(Wm))
        magill.append(switch_delays(Wg))
    moe, magill = np.array(moe), np.array(magill)
    med_moe, med_mag = np.median(moe, axis=0), np.median(magill, axis=0)
    print(f"switch delay after each change (measurements; 101 = never), 10 runs:\n moe   {moe.tolist()}\n"
          f" magill {magill.tolist()}\n medians moe {med_moe} magill {med_mag}")
    # First change (seed 003: gating after 103, Magill after 110).
    assert med_moe[0] <= 10
    assert np.all(moe[:, 0] <= magill[:, 0])
    # Every change: the fading-memory gate switches sooner than never-forgetting Magill.
    assert np.all(med_moe < med_mag)
    assert np.all(np.mean(moe <= 100, axis=0) >= 0.8)


def test_kind_features_learn_a_gate_per_measurement_kind():
    rng = np.random.default_rng(3)
    names = ("radio-expert", "optical-expert")
    net = make_network("moe", names, {"features": "kind", "kinds": ("range", "optical"), "eta": 0.5})
    for k in range(400):
        kind = "range" if k % 2 else "optical"
        good = 0 if kind == "range" else 1
        res = rng.standard_normal((2, 1)) * 3.0  # residual variance 9
        S = np.where(np.arange(2) == good, 9.0, 1.0).reshape(2, 1, 1)  # the other filter's S is too small
        chi2 = (res[:, 0] ** 2) / S[:, 0, 0]
        u = net.update(BankRecord(t=float(k), seq=k, kind=kind, filters=names, residual=res, S=S,
                                  chi2=chi2, processed=np.ones(2, bool)))
        if k >= 398:
            assert np.argmax(u.weights) == good

"""Lubey & Ely 2022 chi-square gating network: eq. 8 against a numerical optimiser, the simplex QP, the
§3.2 rules (G = n_j, batches, reset) and the common network interface."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from fsw.filters.record import BankRecord
from fsw.gating import GatingInputError, InvalidParameterError, UnknownParameterError, make_network
from fsw.gating.chi2 import Chi2Params, closed_form_weights, constrained_weights


def eq5_cost(p, G, Winv, p_prev):
    d = p - p_prev
    return 0.5 * p @ (G * p) + 0.5 * d @ Winv @ d


def scipy_weights(G, W, p_prev, bounds=False):
    """Minimise the Lubey & Ely 2022 eq. 5/6 cost numerically (SLSQP) under 1ᵀp = 1 (and p >= 0)."""
    Winv = np.linalg.inv(W)
    n = len(G)
    res = minimize(
        eq5_cost, np.full(n, 1.0 / n), args=(G, Winv, p_prev),
        jac=lambda p, *a: G * p + Winv @ (p - p_prev),
        constraints=[{"type": "eq", "fun": lambda p: p.sum() - 1.0, "jac": lambda p: np.ones(n)}],
        bounds=[(0.0, 1.0)] * n if bounds else None, method="SLSQP",
        options={"ftol": 1e-14, "maxiter": 1000},
    )
    assert res.success, res.message
    return res.x


def random_spd(rng, n, scale):
    A = rng.standard_normal((n, n))
    return scale * (A @ A.T / n + 0.2 * np.eye(n))


@pytest.mark.parametrize("diagonal", [True, False])
def test_closed_form_matches_numerical_minimum(diagonal):
    rng = np.random.default_rng(11 if diagonal else 12)
    for _ in range(20):
        n = int(rng.integers(2, 7))
        G = rng.uniform(0.1, 5.0, n) * 10 ** rng.uniform(0, 2)
        W = np.diag(rng.uniform(0.5, 2.0, n)) * 0.05**2 if diagonal else random_spd(rng, n, 0.05**2)
        p_prev = rng.dirichlet(np.ones(n))
        p, lam = closed_form_weights(G, W, p_prev)
        ref = scipy_weights(G, W, p_prev)
        np.testing.assert_allclose(p, ref, atol=1e-8)
        assert abs(p.sum() - 1.0) < 1e-12
        # Eq. 7 stationarity with the returned λ.
        np.testing.assert_allclose(G * p + np.linalg.solve(W, p - p_prev) + lam, 0.0, atol=1e-8 * G.max())


def test_simplex_qp_matches_bounded_optimiser_where_eq8_goes_negative():
    rng = np.random.default_rng(5)
    found = 0
    for _ in range(400):
        n = int(rng.integers(3, 6))
        G = rng.uniform(1.0, 200.0, n)
        W = random_spd(rng, n, 0.05**2)
        p_prev = rng.dirichlet(np.full(n, 0.3))
        p_cf, _ = closed_form_weights(G, W, p_prev)
        if p_cf.min() >= -1e-6:
            continue
        found += 1
        p, _ = constrained_weights(G, W, p_prev)
        ref = scipy_weights(G, W, p_prev, bounds=True)
        assert p.min() >= 0.0 and abs(p.sum() - 1.0) < 1e-12
        np.testing.assert_allclose(p, ref, atol=1e-8)
        Winv = np.linalg.inv(W)
        assert eq5_cost(p, G, Winv, p_prev) <= eq5_cost(ref, G, Winv, p_prev) + 1e-10
        if found >= 15:
            break
    assert found >= 15
    # Where eq. 8 is already non-negative the QP returns it unchanged.
    G = np.array([3.0, 5.0, 9.0])
    W = 0.05**2 * np.eye(3)
    np.testing.assert_allclose(constrained_weights(G, W, np.full(3, 1 / 3))[0], closed_form_weights(G, W, np.full(3, 1 / 3))[0], atol=1e-14)


def _record(k, names, res, S, processed, kind="generic-linear", active=None):
    chi2 = np.einsum("ij,ij->i", res, np.linalg.solve(S, res[..., None])[..., 0])
    return BankRecord(t=float(k), seq=k, kind=kind, filters=names, residual=res, S=S, chi2=chi2,
                      processed=np.asarray(processed, dtype=bool), active=active)


def consistent_records(rng, names, count, n=2):
    """Records whose residuals are drawn from each filter's own S (every filter consistent)."""
    N = len(names)
    A = rng.standard_normal((count, N, n, n))
    S = A @ A.transpose(0, 1, 3, 2) + 0.5 * np.eye(n)
    res = np.einsum("knij,knj->kni", np.linalg.cholesky(S), rng.standard_normal((count, N, n)))
    return [_record(k, names, res[k], S[k], np.ones(N)) for k in range(count)]


@pytest.mark.parametrize("network", ["chi2", "chi2-two-sided"])
def test_consistent_filters_stay_near_uniform(network):
    names = ("a", "b", "c", "d")
    net = make_network(network, names, {"batch_size": 200})
    updates = [u for r in consistent_records(np.random.default_rng(2), names, 200 * 40) if (u := net.update(r))]
    assert len(updates) == 40
    W = np.array([u.weights for u in updates])
    np.testing.assert_allclose(W.sum(axis=1), 1.0, atol=1e-12)
    worst = np.abs(W - 0.25).max()
    print(f"{network}: max |p - 1/N| over 40 batches of 200 consistent measurements: {worst:.4f}")
    assert worst < 0.03
    assert [u.batch for u in updates] == list(range(40))


def mixed_stream(rng, M_range, M_optical, optical_bias=0.0):
    """radio processes range (n=1), optical processes optical (n=2), fused both."""
    names = ("radio", "optical", "fused")
    recs = []
    for k in range(M_range + M_optical):
        if k < M_range:
            S = np.full((3, 1, 1), 2.0)
            res = rng.standard_normal((3, 1)) * np.sqrt(2.0)
            recs.append(_record(k, names, res, S, [True, False, True], kind="range"))
        else:
            S = np.tile(np.diag([1.0, 4.0]), (3, 1, 1))
            res = rng.standard_normal((3, 2)) * [1.0, 2.0] + optical_bias
            recs.append(_record(k, names, res, S, [False, True, True], kind="optical"))
    return names, recs


def test_unprocessed_measurements_count_as_nominal():
    rng = np.random.default_rng(8)
    names, recs = mixed_stream(rng, 30, 20, optical_bias=6.0)
    # Hand-computed G_k,i of eq. 6 with the §3.2 rule: unprocessed j contributes n_j.
    chi2 = np.array([r.chi2 for r in recs])
    proc = np.array([r.processed for r in recs])
    dims = np.array([r.n for r in recs])[:, None]
    expected_G = np.where(proc, chi2, dims).sum(axis=0)
    assert expected_G[0] == pytest.approx(chi2[:30, 0].sum() + 2 * 20)
    net = make_network("chi2", names, Chi2Params(batch_size=50))
    updates = [u for r in recs if (u := net.update(r))]
    assert len(updates) == 1
    np.testing.assert_allclose(updates[0].statistic, expected_G, rtol=1e-12)
    np.testing.assert_allclose(updates[0].weights, scipy_weights(expected_G, 0.05**2 * np.eye(3), np.full(3, 1 / 3)), atol=1e-8)
    # The biased optical data penalise the filters that use it, not the radio-only filter.
    assert updates[0].weights[0] > updates[0].weights[1] and updates[0].weights[0] > updates[0].weights[2]
    # Without the substitution the radio-only filter is penalised by data it never uses.
    raw = make_network("chi2", names, Chi2Params(batch_size=50, substitute_unprocessed=False))
    raw_updates = [u for r in recs if (u := raw.update(r))]
    np.testing.assert_allclose(raw_updates[0].statistic, chi2.sum(axis=0), rtol=1e-12)
    assert raw_updates[0].weights[0] < updates[0].weights[0]


def test_batch_without_data_of_one_kind_and_flush():
    rng = np.random.default_rng(9)
    names, recs = mixed_stream(rng, 40, 0)  # a batch holding range data only
    net = make_network("chi2", names, {"batch_size": 40})
    updates = [u for r in recs if (u := net.update(r))]
    assert len(updates) == 1 and updates[0].batch == 0
    assert updates[0].statistic[1] == pytest.approx(40.0)  # optical filter: 40 × n_j = 1, nominal
    assert np.all(updates[0].weights > 0.25)
    _, more = mixed_stream(rng, 5, 7)
    for r in more:
        assert net.update(r) is None
    assert net.state_dict()["pending"] == 12
    net.set_param("final_batch_min", 0.5)
    # a 12-of-40 tail is under half a batch: its weights would be mostly the last batch's
    assert net.flush() is None and net.state_dict()["pending"] == 12
    net.set_param("final_batch_min", 0.0)  # the default: every partial batch closes (Lubey & Ely 2022 §3.2)
    flushed = net.flush()
    assert flushed is not None and flushed.batch == 1 and flushed.seq == more[-1].seq
    assert net.flush() is None


def test_end_of_arc_tail_closes_from_half_a_batch():
    rng = np.random.default_rng(11)
    names, recs = mixed_stream(rng, 30, 0)
    short = make_network("chi2", names, {"batch_size": 40, "final_batch_min": 0.5})
    half = make_network("chi2-two-sided", names, {"batch_size": 40, "final_batch_min": 0.5})
    for r in recs[:19]:
        assert short.update(r) is None
    for r in recs[:20]:
        assert half.update(r) is None
    assert short.flush() is None
    closed = half.flush()
    assert closed is not None and closed.batch == 0 and closed.seq == recs[19].seq


def test_reset_and_parameters():
    rng = np.random.default_rng(10)
    names, recs = mixed_stream(rng, 20, 20, optical_bias=5.0)
    net = make_network("chi2", names, {"batch_size": 10, "sigma_w": 0.2})
    for r in recs:
        net.update(r)
    assert not np.allclose(net.weights, 1 / 3)
    net.update(recs[0])
    net.reset()
    np.testing.assert_allclose(net.weights, 1 / 3)
    st = net.state_dict()
    assert st["batch"] == 0 and st["pending"] == 0
    with pytest.raises(UnknownParameterError):
        net.set_param("sigma", 0.1)
    with pytest.raises(InvalidParameterError):
        net.set_param("sigma_w", -1.0)
    with pytest.raises(InvalidParameterError):
        net.set_param("memory_matrix", [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    with pytest.raises(InvalidParameterError):
        make_network("chi2", names, {"batch_size": 0})
    net.set_param("batch_size", 5.0)  # telecommand values arrive as floats
    assert net.params.batch_size == 5
    net.set_param("memory_matrix", (0.01 * np.eye(3) + 0.001).tolist())
    for r in recs[:5]:
        u = net.update(r)
    assert u is not None and abs(u.weights.sum() - 1.0) < 1e-12


def test_clip_policy_and_bad_records():
    names = ("a", "b")
    net = make_network("chi2", names, {"batch_size": 1, "negative_weights": "clip"})
    S = np.tile(np.eye(1), (2, 1, 1))
    u = net.update(_record(0, names, np.array([[0.1], [30.0]]), S, [True, True]))
    assert u.weights.min() >= 0.0 and abs(u.weights.sum() - 1.0) < 1e-12
    bad = BankRecord(t=1.0, seq=1, kind="range", filters=names, residual=np.array([[np.nan], [0.0]]),
                     S=S, chi2=np.array([np.nan, 0.0]), processed=np.ones(2, bool))
    with pytest.raises(GatingInputError):
        net.update(bad)
    with pytest.raises(GatingInputError):
        net.update(_record(2, ("a", "c"), np.zeros((2, 1)), S, [True, True]))
    assert net.state_dict()["rejected"] == 2


def test_disabled_filter_gets_zero_and_reenters_at_prior_share():
    rng = np.random.default_rng(4)
    names = ("a", "b", "c")
    recs = consistent_records(rng, names, 60)
    net = make_network("chi2", names, {"batch_size": 10})
    off = np.array([True, False, True])
    for r in recs[:30]:
        u = net.update(BankRecord(**{**{f: getattr(r, f) for f in r.__slots__}, "active": off}))
    assert u.weights[1] == 0.0 and abs(u.weights.sum() - 1.0) < 1e-12
    net.update(recs[30])
    assert net.weights[1] == pytest.approx(1 / 3)
    for r in recs[31:40]:
        u = net.update(r)
    assert u is not None and np.all(u.weights > 0.25)


@pytest.mark.parametrize("policy", ["qp", "clip"])
def test_network_handles_negative_closed_form(policy):
    rng = np.random.default_rng(13)
    n = 4
    # A filter that earned a small weight, surrounded by much worse ones: eq. 8 goes negative.
    for _ in range(2000):
        W = random_spd(rng, n, 0.05**2)
        G = rng.uniform(1.0, 400.0, n)
        p0 = rng.dirichlet(np.full(n, 0.3))
        if scipy_weights(G, W, p0).min() < -1e-3:
            break
    else:
        pytest.fail("no case with a negative eq. 8 weight found")
    names = tuple("abcd")
    p0 = p0 / p0.sum()
    net = make_network("chi2", names, {"batch_size": 1, "memory_matrix": W.tolist(), "negative_weights": policy,
                                       "prior": tuple(p0)})
    np.testing.assert_allclose(net.weights, p0)
    rec = _record(0, names, np.sqrt(G)[:, None], np.tile(np.eye(1), (n, 1, 1)), np.ones(n))
    u = net.update(rec)
    if policy == "qp":
        expected = scipy_weights(G, W, p0, bounds=True)
    else:
        raw = np.clip(scipy_weights(G, W, p0), 0.0, None)
        expected = raw / raw.sum()
    print(f"{policy}: eq. 8 {np.round(scipy_weights(G, W, p0), 4)} -> {np.round(u.weights, 4)}")
    np.testing.assert_allclose(u.weights, expected, atol=1e-7)
    assert u.weights.min() >= 0.0 and u.weights.sum() == pytest.approx(1.0)

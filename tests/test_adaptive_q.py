"""The adaptive state-noise filter mode (Garhwal, Halder & Sinha): Tanaka FLR slope, least-squares
slope, eq. 1 Q, the counted fallbacks, and an EKF flying with the mode on."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog

from fsw.filters.adaptive_q import AdaptiveQ, AdaptiveQConfig, eq1_q, flr_line, lsq_slope
from fsw.filters.config import BankConfig, FilterConfig


def _envelope_line(t: np.ndarray, y: np.ndarray, upper: bool) -> tuple[float, float]:
    """Brute force: of the lines through two samples that stay on one side of every sample, the
    one with the least Σ|line − y| (the LP optimum lies at such a vertex)."""
    best: tuple[float, float, float] | None = None
    for j, k in itertools.combinations(range(t.size), 2):
        b = (y[k] - y[j]) / (t[k] - t[j])
        a = y[j] - b * t[j]
        d = a + b * t - y
        if (upper and np.all(d >= -1e-12)) or (not upper and np.all(d <= 1e-12)):
            cost = float(np.abs(d).sum())
            if best is None or cost < best[0]:
                best = (cost, a, b)
    assert best is not None
    return best[1], best[2]


def _band_lp(t: np.ndarray, y: np.ndarray) -> float:
    """The same problem in another layout — lower and upper h-level lines (a_l, b_l, a_u, b_u) —
    by the dual simplex: minimise Σ (U − L)(t_j) with L(t_j) ≤ y_j ≤ U(t_j), a_u ≥ a_l, b_u ≥ b_l."""
    m = t.size
    cost = np.array([-m, -t.sum(), m, t.sum()], dtype=float)
    a = np.vstack([np.column_stack([np.ones(m), t, np.zeros(m), np.zeros(m)]),
                   np.column_stack([np.zeros(m), np.zeros(m), -np.ones(m), -t]),
                   [[1.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, -1.0]]])
    b = np.concatenate([y, -y, [0.0, 0.0]])
    res = linprog(cost, A_ub=a, b_ub=b, bounds=[(None, None)] * 4, method="highs-ds")
    assert res.status == 0
    return float(res.fun)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("h", [0.0, 0.5])
def test_flr_matches_independent_formulations(seed: int, h: float) -> None:
    rng = np.random.default_rng(seed)
    m = int(rng.integers(3, 9))
    t = np.sort(rng.uniform(0.0, 20.0, m))
    t -= t[0]
    y = 0.3 * t + rng.normal(0.0, 1.0, m)
    fit = flr_line(t, y, h)
    assert fit.status == 0
    w = 1.0 - h
    # eq. 10 objective equals the band width summed over the samples, over 2(1 − h)
    total_spread = m * fit.c0 + fit.c1 * t.sum()
    assert total_spread * 2 * w == pytest.approx(_band_lp(t, y), rel=1e-7, abs=1e-9)
    a_u, b_u = _envelope_line(t, y, upper=True)
    a_l, b_l = _envelope_line(t, y, upper=False)
    if b_u >= b_l:  # the spread constraints c ≥ 0 are slack: the vertices are the envelope lines
        assert fit.p1 == pytest.approx((b_u + b_l) / 2, rel=1e-7, abs=1e-9)
        assert fit.p0 == pytest.approx((a_u + a_l) / 2, rel=1e-7, abs=1e-9)
        assert fit.c1 * w == pytest.approx((b_u - b_l) / 2, rel=1e-7, abs=1e-9)
    # every sample lies in its h-level band (eqs. 11-12)
    half = w * (fit.c0 + fit.c1 * t)
    assert np.all(y >= fit.p0 + fit.p1 * t - half - 1e-9)
    assert np.all(y <= fit.p0 + fit.p1 * t + half + 1e-9)


def test_flr_on_a_crisp_line_is_exact() -> None:
    t = np.arange(10.0)
    fit = flr_line(t, 2.0 - 0.25 * t, 0.3)
    assert (fit.p0, fit.p1) == (pytest.approx(2.0), pytest.approx(-0.25))
    assert fit.c0 == pytest.approx(0.0, abs=1e-12) and fit.c1 == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_lsq_slope_matches_polyfit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 50.0, 10))
    y = rng.normal(0.0, 3.0, 10) - 0.7 * t
    assert lsq_slope(t, y) == pytest.approx(np.polyfit(t, y, 1)[0], rel=1e-10)


def test_eq1_q_is_the_diagonal_of_residual_times_slope() -> None:
    r = np.array([1.0, -2.0, 3.0, -4e-3, 5e-3, 6e-3])
    s = np.array([-0.5, -0.5, 2.0, 1e-4, -1e-4, 0.0])
    q = eq1_q(r, s)
    for i, j in itertools.product(range(6), range(6)):
        assert q[i, j] == (abs(r[i] * s[i]) if i == j else 0.0)


def _fed(cfg: AdaptiveQConfig, times: np.ndarray, residuals: np.ndarray) -> AdaptiveQ:
    aq = AdaptiveQ(cfg)
    for t, r in zip(times, residuals):
        aq.add(float(t), r)
    return aq


def test_window_warmup_and_q() -> None:
    cfg = AdaptiveQConfig(mode="lsq-adaptive", window=4, warmup=3)
    times = np.arange(6.0) * 60.0
    res = np.outer(times**2 / 3600.0, np.ones(6))
    aq = AdaptiveQ(cfg)
    for k, (t, r) in enumerate(zip(times, res)):
        aq.add(float(t), r)
        assert aq.active == (k >= 2)
        assert np.all(aq.q_diagonal(60.0) == 0.0) == (k < 2)
    t_w, r_w = aq.window()
    assert t_w.tolist() == [0.0, 60.0, 120.0, 180.0]  # the last λ = 4, oldest first
    expected = abs(res[-1, 0] * np.polyfit(times[-4:], res[-4:, 0], 1)[0]) * 60.0
    assert aq.q_diagonal(60.0) == pytest.approx(np.full(6, expected))


def test_degenerate_window_falls_back_without_raising() -> None:
    cfg = AdaptiveQConfig(mode="fuzzy-adaptive", window=3, warmup=3)
    aq = _fed(cfg, np.array([0.0, 1.0, 2.0]), np.outer([1.0, 2.0, 4.0], np.ones(6)))
    assert aq.counters.lp_failures == 0
    aq.add(5.0, np.full(6, 3.0))
    aq.add(5.0, np.full(6, 3.0))  # window times (2, 5, 5): still a span
    q_before = aq.q_diagonal(1.0).copy()
    assert np.all(q_before > 0) and aq.counters.lp_failures == 0
    aq.add(5.0, np.full(6, 3.0))  # all-equal times: no slope exists, the previous Q stays
    assert aq.counters.lp_failures == 6 and aq.counters.fallback_previous == 6
    assert aq.counters.lp_solves == 6 * 3
    assert np.array_equal(aq.q_diagonal(1.0), q_before)


def test_infeasible_lp_counted_and_falls_back_to_lsq() -> None:
    # a big M far smaller than the residuals: no fuzzy line fits within the bound
    cfg = AdaptiveQConfig(mode="fuzzy-adaptive", window=5, warmup=5, big_m=(1e-6,) * 6)
    times = np.arange(5.0)
    res = np.outer([1.0, 3.0, 2.0, 5.0, 4.0], np.ones(6))
    aq = _fed(cfg, times, res)
    assert aq.counters.lp_failures == 6 and aq.counters.fallback_lsq == 6
    assert aq.q_diagonal(1.0) == pytest.approx(np.full(6, 4.0 * np.polyfit(times, res[:, 0], 1)[0]))


def test_fuzzy_slope_used_and_lp_cost_counted() -> None:
    cfg = AdaptiveQConfig(mode="fuzzy-adaptive", window=10, warmup=10, h=0.2)
    rng = np.random.default_rng(3)
    times = np.arange(10.0)
    res = rng.normal(0.0, 1.0, (10, 6))
    aq = _fed(cfg, times, res)
    slopes = np.array([flr_line(times, res[:, i], 0.2).p1 for i in range(6)])
    assert aq.q_diagonal(1.0) == pytest.approx(np.abs(res[-1] * slopes))
    assert aq.counters.lp_solves == 6 and aq.counters.lp_failures == 0
    assert aq.counters.lp_mean_us > 0.0


def test_config_rejects_bad_values() -> None:
    with pytest.raises(ValueError):
        AdaptiveQConfig(mode="lsq-adaptive", window=5, warmup=6)
    with pytest.raises(ValueError):
        AdaptiveQConfig(big_m=(1.0, 1.0, 1.0, 1.0, 1.0, -1.0))


def test_ekf_with_fuzzy_mode_runs_and_inflates_p() -> None:
    """Two EKFs of one stack fly the same position fixes: the fuzzy-adaptive one adds eq. 1 Q once
    warm, the fixed one is untouched by the mode."""
    from fsw.filters.ekf import EKFStack
    from fsw.models.environment import Environment
    from tools.bench.synthetic import entry_state

    adaptive = AdaptiveQConfig(mode="fuzzy-adaptive", window=5, warmup=5, h=0.1)
    bank = BankConfig(filters=(FilterConfig(name="fixed"), FilterConfig(name="fuzzy", process_noise=adaptive)))
    t0, r0, v0 = entry_state()
    t0 -= 2 * 86400.0
    st = EKFStack(bank, t0, r0, v0, Environment())
    truth = EKFStack(BankConfig(filters=(FilterConfig(name="t"),)), t0, np.asarray(r0) + 5.0, v0, Environment())
    rng = np.random.default_rng(1)
    n = st.layout.n
    H = np.zeros((2, 3, n))
    H[:, np.arange(3), np.arange(3)] = 1.0
    R = np.broadcast_to(np.eye(3), (2, 3, 3)).copy()
    for k in range(8):
        t = t0 + 600.0 * (k + 1)
        st.propagate_to(t)
        truth.propagate_to(t)
        p_before = st.P[:, 0:6, 0:6].diagonal(axis1=1, axis2=2).copy()
        y = truth.x[0, 0:3] + rng.normal(0.0, 1.0, 3)
        _, _, _, processed = st.update(y, st.x[:, 0:3], H, R, np.ones(2, bool), None)
        assert processed.all()
    aq = st.adaptive_q[1]
    assert st.adaptive_q[0] is None and aq is not None and aq.active
    assert aq.counters.lp_solves == 6 * 4 and aq.counters.lp_failures == 0
    added = aq.q_diagonal(600.0)
    assert np.all(added >= 0.0) and np.any(added > 0.0)
    st.propagate_to(st.t + 600.0)
    assert np.all(np.isfinite(st.P)) and np.all(np.isfinite(st.x))
    print(f"FLR LP: {aq.counters.lp_mean_us:.0f} us per solve over {aq.counters.lp_solves} solves")


def test_yaml_mapping_decodes_and_bad_values_are_one_line_errors() -> None:
    from fsw.interface.typed import DecodeError, decode

    f = decode(FilterConfig, {"name": "a", "process_noise": {"mode": "fuzzy-adaptive", "h": 0.2,
                                                             "big_m": [1, 1, 1, 1e-3, 1e-3, 1e-3]}})
    assert f.process_noise.mode == "fuzzy-adaptive" and f.process_noise.big_m == (1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3)
    assert decode(FilterConfig, {"name": "a"}).process_noise.mode == "fixed"
    for bad in ({"mode": "fuzzy"}, {"h": 1.0}, {"window": 5, "warmup": 6}):
        with pytest.raises(DecodeError, match="process_noise"):
            decode(FilterConfig, {"name": "a", "process_noise": bad})


@pytest.mark.slow
def test_short_scenario_flies_in_process_with_a_fuzzy_adaptive_filter(short_e2e_yaml: str) -> None:
    from fsw.interface import typed
    from tools.campaign.plan import merge
    from tools.inprocess import run_in_process
    from tools.scenario import ScenarioConfig, load_text_scenario

    data = typed.encode(load_text_scenario(short_e2e_yaml))
    merge(data, {"sim.trajectory.span_days": 2.0})
    fuzzy = data["fsw"]["bank"]["filters"][0]
    fuzzy["process_noise"] = {"mode": "fuzzy-adaptive", "window": 10, "warmup": 10, "h": 0.0}
    result = run_in_process(typed.decode(ScenarioConfig, data), 2)
    assert fuzzy["name"] in result.summary.filters
    estimates = result.topic("fsw/estimate/" + fuzzy["name"])
    assert estimates and all(np.isfinite(e.position_sigma_km) and e.position_sigma_km > 0 for e in estimates)
    final = result.topic("fsw/status")[-1].counts
    assert final["adaptive_lp_solves"] > 0 and final["adaptive_lp_us"] > 0


def test_lp_cost_is_declared_to_the_bank_stage_and_counted_in_status() -> None:
    """Work-unit mode: each enabled fuzzy-adaptive filter adds lp_cost per state to the bank stage;
    the LP count, failures, fallbacks and CPU go out as RunStatus counters."""
    from fsw.core.pipeline import Load, bank_cost
    from fsw.executive.config import BudgetConfig
    from fsw.filters.bank import FilterBank
    from fsw.models.environment import Environment
    from tools.bench.synthetic import entry_state

    fuzzy = AdaptiveQConfig(mode="fuzzy-adaptive", window=5, warmup=5, lp_cost=7.0)
    lsq = AdaptiveQConfig(mode="lsq-adaptive", window=5, warmup=5)
    cfg = BankConfig(filters=(FilterConfig(name="fixed"), FilterConfig(name="fuzzy", process_noise=fuzzy),
                              FilterConfig(name="lsq", process_noise=lsq)))
    t0, r0, v0 = entry_state()
    bank = FilterBank(cfg, t0 - 86400.0, r0, v0, Environment())
    assert bank.adaptive_lp_cost() == 6 * 7.0
    bank.set_enabled("fuzzy", False)
    assert bank.adaptive_lp_cost() == 0.0
    bank.set_enabled("fuzzy", True)
    budget = BudgetConfig(mode="work-units")
    plain = bank_cost(budget, Load(active_filters=3, networks=1))
    assert bank_cost(budget, Load(3, 1, adaptive_lp=bank.adaptive_lp_cost())) == plain + 42.0
    st = bank.stack
    n = st.layout.n
    H = np.zeros((3, 3, n))
    H[:, np.arange(3), np.arange(3)] = 1.0
    R = np.broadcast_to(np.eye(3), (3, 3, 3)).copy()
    rng = np.random.default_rng(2)
    for k in range(7):
        st.propagate_to(st.t + 60.0)
        st.update(st.x[0, 0:3] + rng.normal(0.0, 1.0, 3), st.x[:, 0:3], H, R, np.ones(3, bool), None)
    counts = bank.adaptive_counts()
    assert counts["adaptive_lp_solves"] == 6 * 3 and counts["adaptive_lp_failures"] == 0
    assert counts["adaptive_lp_us"] > 0 and counts["adaptive_fallback_lsq"] == 0
    plain_bank = FilterBank(BankConfig(filters=(FilterConfig(name="fixed"),)), t0 - 86400.0, r0, v0, Environment())
    assert plain_bank.adaptive_counts() == {} and plain_bank.adaptive_lp_cost() == 0.0

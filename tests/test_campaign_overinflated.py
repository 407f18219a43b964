"""The over-inflated filter (Lubey & Ely 2022 §3.2's weakness of the chi-square network) and chi2-two-sided."""

from __future__ import annotations

from fsw.interface import typed
from tools.campaign.plan import expand, merge
from tools.campaign.spec import load_campaign
from tools.inprocess import run_in_process
from tools.scenario import ScenarioConfig, load_scenario


def test_scenario_and_campaign_are_what_they_claim():
    scen = load_scenario("insight-overinflated")
    filters = {f.name: f for f in scen.fsw.bank.filters}
    assert list(filters) == ["radio", "optical", "fused", "fused-inflated"]
    inflated, fused = filters["fused-inflated"], filters["fused"]
    assert inflated.sigma_scale == {"range": 3.0, "doppler": 3.0, "optical": 3.0} and not fused.sigma_scale
    # the inflated filter is the fused one in every other respect
    assert typed.encode(inflated) | {"name": "fused", "sigma_scale": {}} == typed.encode(fused)
    assert [g.network for g in scen.fsw.gating] == ["chi2", "chi2-two-sided"]
    assert scen.sim.faults == () and scen.fsw.detector.calibration is None
    plan = expand(load_campaign("overinflated"))
    assert len(plan.tasks) == 100 and {t.seed for t in plan.tasks} == set(range(1, 101))
    assert all(t.fault_class == "none" and not t.detector_calibrated for t in plan.tasks)
    assert all(t.extract_weights == ("chi2", "chi2-two-sided") for t in plan.tasks)


def test_chi2_prefers_the_inflated_filter_and_the_two_sided_network_does_not():
    data = typed.encode(load_scenario("insight-overinflated"))
    merge(data, {"sim.trajectory.span_days": 8.0})  # five chi2 batches of 1000 measurements
    summary = run_in_process(typed.decode(ScenarioConfig, data), 3).summary
    chi2 = summary.gating["chi2"].mean_weights
    two = summary.gating["chi2-two-sided"].mean_weights
    assert max(chi2, key=chi2.get) == "fused-inflated" and chi2["fused-inflated"] > 0.5
    assert min(two, key=two.get) == "fused-inflated" and two["fused-inflated"] < 0.2
    # the healthy, consistent filters keep about equal shares under the two-sided network
    assert max(two[f] for f in ("radio", "optical", "fused")) - min(two[f] for f in ("radio", "optical", "fused")) < 0.05

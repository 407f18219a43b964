"""Campaign statistics on hand-made rows, checked against hand computations and scipy."""

import json
import math

import numpy as np
import pytest
from scipy import optimize, stats

from campaign_rows import complete_row
from ground.report.row_types import ResultRow
from tools.campaign.plan_file import PlanFile
from tools.campaign.report import render
from tools.campaign.stats import binomial, compute, latency_stats, poisson_rate
from tools.cli import main

H = 3600.0


def _summary(*, declared=False, false_alarm=False, latency_h=None, cls="none", true_class="none",
             time_day=None, weights=(1 / 3, 1 / 3, 1 / 3), rms=(1.0, 2.0, 3.0), util=0.1, overruns=0, backlog=0):
    f = ["radio", "optical", "fused"]
    return {
        "filters": f,
        "gating": {"chi2": {"mean_weights": dict(zip(f, weights)), "final_weights": dict(zip(f, weights))}},
        "anomaly": {"declared": declared, "false_alarm": false_alarm,
                    "latency_s": None if latency_h is None else latency_h * H, "class": cls if declared else "none",
                    "true_class": true_class, "time_day": time_day,
                    "correct_class": (cls == true_class) if declared else None},
        "position_error_rms_km": dict(zip(f, rms)),
        "budget": {"max_utilisation": util, "overruns": overruns, "final_backlog": backlog, "max_backlog": backlog},
    }


def _row(rid, fault, seed, summary, *, fault_class, calibrated=True, status="ok", span=10.0):
    return complete_row({"id": rid, "cell": {"scenario": "s", "fault": fault, "variant": "v"}, "seed": seed,
            "fault_class": fault_class, "detector": {"network": "chi2", "calibrated": calibrated},
            "span_days": span, "status": status, "summary": summary if status == "ok" else None,
            "error": None if status == "ok" else {"type": "ValueError", "message": "boom"}, "wall_time_s": 2.0})


def _decoded(rows):
    return [ResultRow.from_json(r) for r in rows]


OPT = "optical-measurement"
RAD = "radiometric-measurement"


def _rows():
    rows = [
        # nominal: one false alarm on day 2.5 out of four 10-day runs
        _row("n1", "none", 1, _summary(declared=True, false_alarm=True, cls=OPT, time_day=2.5), fault_class="none"),
        _row("n2", "none", 2, _summary(), fault_class="none"),
        _row("n3", "none", 3, _summary(), fault_class="none"),
        _row("n4", "none", 4, _summary(), fault_class="none"),
        # optical bias: 3 detections (latencies 2, 4, 10 h; one wrongly classed), 1 miss, 1 early false alarm
        _row("o1", "ob", 1, _summary(declared=True, latency_h=2.0, cls=OPT, true_class=OPT, time_day=5.1,
                                     weights=(0.8, 0.1, 0.1), rms=(1.0, 5.0, 4.0)), fault_class=OPT),
        _row("o2", "ob", 2, _summary(declared=True, latency_h=4.0, cls=RAD, true_class=OPT, time_day=5.2,
                                     weights=(0.6, 0.2, 0.2), rms=(2.0, 7.0, 6.0), overruns=2, backlog=3),
             fault_class=OPT),
        _row("o3", "ob", 3, _summary(declared=True, latency_h=10.0, cls=OPT, true_class=OPT, time_day=5.4,
                                     weights=(0.7, 0.2, 0.1), rms=(3.0, 9.0, 5.0), util=0.9), fault_class=OPT),
        _row("o4", "ob", 4, _summary(true_class=OPT, weights=(0.4, 0.3, 0.3)), fault_class=OPT),
        _row("o5", "ob", 5, _summary(declared=True, false_alarm=True, cls=OPT, true_class=OPT, time_day=1.0,
                                     weights=(0.5, 0.25, 0.25)), fault_class=OPT),
        _row("o6", "ob", 6, None, fault_class=OPT, status="failed"),
    ]
    # an earlier failed attempt of o1, superseded by the row above
    return [_row("o1", "ob", 1, None, fault_class=OPT, status="failed")] + rows


def _cell(s, fault):
    return next(c for c in s["cells"] if c["fault"] == fault)


@pytest.mark.parametrize("k,n", [(0, 1), (0, 20), (1, 4), (3, 5), (7, 10), (20, 20), (13, 600)])
def test_clopper_pearson_against_beta_quantiles_and_binomial_tails(k, n):
    b = binomial(k, n, 0.95).to_json()
    lo, hi = b["ci"]
    # the textbook Beta-quantile form, computed here directly
    exp_lo = 0.0 if k == 0 else stats.beta(k, n - k + 1).ppf(0.025)
    exp_hi = 1.0 if k == n else stats.beta(k + 1, n - k).ppf(0.975)
    assert lo == pytest.approx(exp_lo, abs=1e-12) and hi == pytest.approx(exp_hi, abs=1e-12)
    # the defining property: each tail of the binomial at the bound holds alpha/2
    if k > 0:
        assert stats.binom.sf(k - 1, n, lo) == pytest.approx(0.025, rel=1e-6)
    if k < n:
        assert stats.binom.cdf(k, n, hi) == pytest.approx(0.025, rel=1e-6)
    assert b["rate"] == k / n


def test_poisson_rate_interval_against_tail_equations():
    r = poisson_rate(1, 32.5, 0.95).to_json()
    assert r["per_day"] == pytest.approx(1 / 32.5)
    lo, hi = r["ci"]
    assert lo == pytest.approx(-math.log(0.975) / 32.5, rel=1e-9)  # P(N >= 1) = 1 - exp(-mu) = 0.025
    mu_hi = optimize.brentq(lambda mu: stats.poisson.cdf(1, mu) - 0.025, 0.1, 50.0, xtol=1e-12)
    assert hi == pytest.approx(mu_hi / 32.5, rel=1e-8)
    r0 = poisson_rate(0, 10.0).to_json()
    assert r0["ci"][0] == 0.0 and r0["ci"][1] == pytest.approx(-math.log(0.025) / 10.0, rel=1e-9)


def test_latency_percentiles_by_hand():
    lat = latency_stats([2 * H, 4 * H, 10 * H]).to_json()
    assert lat["median_h"] == pytest.approx(4.0)
    assert lat["p90_h"] == pytest.approx(4.0 + 0.8 * (10.0 - 4.0))  # rank 0.9 * 2 = 1.8
    lat4 = latency_stats([1 * H, 2 * H, 3 * H, 9 * H]).to_json()
    assert lat4["median_h"] == pytest.approx(2.5) and lat4["p90_h"] == pytest.approx(3.0 + 0.7 * 6.0)
    assert latency_stats([]) is None


def test_cell_statistics_on_hand_made_rows():
    s = compute(_decoded(_rows())).to_json()
    ob = _cell(s, "ob")
    assert ob["runs"]["ok"] == 5 and ob["runs"]["failed"] == 1
    assert ob["detection"]["k"] == 3 and ob["detection"]["n"] == 5
    assert ob["detection"]["ci"] == pytest.approx([stats.beta(3, 3).ppf(0.025), stats.beta(4, 2).ppf(0.975)])
    assert ob["false_alarm"]["per_run"]["k"] == 1  # the early declaration is not a detection
    assert ob["latency"]["median_h"] == pytest.approx(4.0) and ob["latency"]["p90_h"] == pytest.approx(8.8)
    assert ob["characterization"]["k"] == 2 and ob["characterization"]["n"] == 3
    assert ob["weights"]["chi2"]["mean"]["radio"] == pytest.approx(np.mean([0.8, 0.6, 0.7, 0.4, 0.5]))
    pe = ob["position_error_rms_km"]["optical"]
    assert pe["mean"] == pytest.approx(np.mean([5, 7, 9, 2, 2])) and pe["median"] == 5.0 and pe["max"] == 9.0
    assert ob["budget"] == {"max_utilisation": 0.9, "overruns_total": 2, "runs_with_overruns": 1,
                            "final_backlog_max": 3, "max_backlog": 3}
    none = _cell(s, "none")
    assert none["detection"] is None
    assert none["false_alarm"]["per_run"]["k"] == 1 and none["false_alarm"]["per_run"]["n"] == 4
    day = none["false_alarm"]["per_day"]
    assert day["exposure_days"] == pytest.approx(2.5 + 3 * 10.0) and day["per_day"] == pytest.approx(1 / 32.5)


def test_confusion_matrix_by_hand():
    s = compute(_decoded(_rows())).to_json()
    (g,) = s["confusion"]
    assert g["true_classes"] == ["none", OPT]
    assert g["matrix"]["none"] == {"none": 3, OPT: 1, RAD: 0}
    assert g["matrix"][OPT] == {"none": 1, OPT: 3, RAD: 1}


def test_uncalibrated_cells_report_na_and_weight_table_layout():
    rows = [_row(f"u{i}", "none", i, _summary(), fault_class="none", calibrated=False) for i in range(3)]
    rows += [_row(f"v{i}", "ob", i, _summary(weights=(0.9, 0.05, 0.05), true_class=OPT), fault_class=OPT,
                  calibrated=False) for i in range(3)]
    s = compute(_decoded(rows)).to_json()
    assert all(c["detection"] is None and c["false_alarm"] is None for c in s["cells"])
    assert s["confusion"] == []
    (t,) = s["weight_tables"]
    assert t["network"] == "chi2" and t["filters"] == ["radio", "optical", "fused"]
    assert [r["case"] for r in t["rows"]] == ["none", "ob"]
    assert t["rows"][1]["mean"]["radio"] == pytest.approx(0.9)


def test_plan_gives_missing_runs_and_ignores_stale_rows():
    rows = _rows()
    plan = {"name": "p", "cells": [{"scenario": "s", "fault": "none", "variant": "v", "key": "s / none / v"}],
            "runs": [{"id": f"n{i}", "cell": "s / none / v", "seed": i} for i in range(1, 7)]}
    s = compute(_decoded(rows), PlanFile.from_json(plan)).to_json()
    assert [c["fault"] for c in s["cells"]] == ["none"]
    assert s["runs"]["planned"] == 6 and s["runs"]["missing"] == 2 and s["runs"]["stale_rows"] == 6
    assert _cell(s, "none")["runs"]["missing"] == 2


def test_stats_only_command_writes_summary_and_report(tmp_path, capsys):
    (tmp_path / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in _rows()) + '{"id": "torn')
    assert main(["campaign", "--stats-only", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["runs"]["torn_tail"] and summary["runs"]["ok"] == 9
    report = (tmp_path / "report.md").read_text()
    assert "| s | ob | v | chi2 | 5 (+1 failed) | 3/5 = 60.0 % [14.7, 94.7] |" in report
    assert "| Ideal | 0.3333 | 0.3333 | 0.3333 |" in report
    assert "## Failed runs" in report and "ValueError: boom" in report
    assert main(["campaign", "--stats-only", str(tmp_path / "nothing-here")]) == 2


def test_planned_cell_without_rows_keeps_its_fault_class():
    plan = {"name": "p", "cells": [{"scenario": "s", "fault": "big", "variant": "v", "key": "s / big / v",
                                    "fault_class": OPT, "detector": {"network": "magill", "calibrated": True}}],
            "runs": [{"id": "x1", "cell": "s / big / v", "seed": 1}]}
    computed = compute([], PlanFile.from_json(plan))
    (c,) = computed.to_json()["cells"]
    assert c["fault_class"] == OPT and c["detector"]["network"] == "magill"
    assert c["detection"]["n"] == 0 and c["detection"]["rate"] is None and c["runs"]["missing"] == 1
    assert "| s | big | v | magill | 0 | n/a |" in render(computed)

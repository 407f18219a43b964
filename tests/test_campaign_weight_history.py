"""Weight-history figures of a campaign (keep_weights): median and 10-90 % band over seeds per fault case."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from ground.report import campaign_data as C
from ground.report.campaign_plots import plot_weight_history, write_campaign_figures
from ground.report.run_weights import RunWeights
from tools.campaign.store import RunStore

T0 = 5.0e8
DAY = 86400.0
FILTERS = ["radio", "optical", "fused"]


def _row(rid, fault, seed, *, t0=True, onset_day=None):
    tc = "none" if fault == "none" else "optical-measurement"
    anomaly = {"declared": False, "false_alarm": False, "class": "none", "true_class": tc,
               "onset_true": None if onset_day is None else T0 + onset_day * DAY, "onset_true_day": onset_day}
    summary = {"gating": {"chi2": {"mean_weights": dict(zip(FILTERS, (1 / 3,) * 3))}}, "anomaly": anomaly}
    if t0:
        summary["t0"] = T0
    return {"id": rid, "cell": {"scenario": "s", "fault": fault, "variant": "v"}, "seed": seed, "status": "ok",
            "fault_class": tc, "detector": {"network": "chi2", "calibrated": False}, "summary": summary}


def _history(days, radio):
    radio = np.asarray(radio, dtype=float)
    w = np.column_stack([radio, (1 - radio) / 2, (1 - radio) / 2])
    return RunWeights(filters=tuple(FILTERS), t_s=T0 + np.asarray(days) * DAY, batch=np.arange(len(days)), weights=w)


@pytest.fixture
def campaign(tmp_path):
    rows = [_row("n1", "none", 1), _row("n2", "none", 2),
            # the faulted runs' start epoch comes from their onset (no t0 in these summaries)
            _row("f1", "ob", 1, t0=False, onset_day=1.0), _row("f2", "ob", 2, t0=False, onset_day=1.0),
            _row("f3", "ob", 3, t0=False, onset_day=1.2)]
    with RunStore(tmp_path) as store:
        store.save_weights("n1", {"chi2": _history([0.5, 1.0, 1.5], [0.3, 0.3, 0.3])})
        store.save_weights("n2", {"chi2": _history([0.6, 1.1, 1.6], [0.4, 0.4, 0.4])})
        store.save_weights("f1", {"chi2": _history([0.5, 1.5], [0.3, 0.6])})
        store.save_weights("f2", {"chi2": _history([0.5, 1.5], [0.3, 0.8])})
        store.save_weights("f3", {"chi2": _history([0.5, 1.5], [0.3, 0.9])})
    with open(tmp_path / "runs.jsonl", "w") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
    return C.load_campaign(tmp_path)


def test_median_and_band_over_seeds_by_hand(campaign):
    assert C.kept_networks(campaign) == ["chi2"]
    wh = C.weight_history(campaign, "chi2", "s", "v", points=41)  # grid step 0.04 day
    assert wh.cases == ["none", "ob"] and wh.filters == FILTERS and list(wh.n) == [2, 3]
    assert wh.days[0] == 0.0 and wh.days[-1] == pytest.approx(1.6)
    i = int(np.argmin(abs(wh.days - 1.52)))  # after every run's last batch
    # ob at that epoch: radio 0.6, 0.8, 0.9 -> median 0.8; 10th percentile 0.6 + 0.2 (0.8 - 0.6);
    # 90th 0.8 + 0.8 (0.9 - 0.8) (linear between order statistics)
    assert wh.median[1, i, 0] == pytest.approx(0.8)
    assert wh.p10[1, i, 0] == pytest.approx(0.64) and wh.p90[1, i, 0] == pytest.approx(0.88)
    assert wh.median[1, i, 1] == pytest.approx(0.1)
    # nominal: before n2's first batch (day 0.6) only n1 counts; between 0.6 and 1.5 both
    j = int(np.argmin(abs(wh.days - 0.52)))
    assert wh.median[0, j, 0] == pytest.approx(0.3)
    k = int(np.argmin(abs(wh.days - 0.8)))
    assert wh.median[0, k, 0] == pytest.approx(0.35)
    assert np.all(np.isnan(wh.median[:, 0, :]))  # no batch yet on day 0
    assert np.isnan(wh.onset_day[0]) and wh.onset_day[1] == pytest.approx(1.0)


def test_figure_draws_the_medians_and_marks_the_onset(campaign):
    wh = C.weight_history(campaign, "chi2", "s", "v")
    fig = plot_weight_history(wh)
    ax = fig.axes[1]  # the 'ob' panel
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == len(wh.days)]
    np.testing.assert_array_equal(lines[0].get_ydata(), wh.median[1, :, 0])
    onset = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--" and ln.get_color() == "tab:red"]
    assert onset and onset[0].get_xdata()[0] == pytest.approx(1.0)
    names = {p.name for p in write_campaign_figures(campaign, campaign.path / "fig")}
    assert "weights_vs_time_chi2_s.png" in names


def test_no_kept_weights_no_history_figure(campaign, tmp_path_factory):
    bare = tmp_path_factory.mktemp("bare")
    (bare / "runs.jsonl").write_text((campaign.path / "runs.jsonl").read_text())
    camp = C.load_campaign(bare)
    assert C.kept_networks(camp) == [] and C.weight_history(camp, "chi2", "s", "v") is None
    names = {p.name for p in write_campaign_figures(camp, bare / "fig")}
    assert names and not any(n.startswith("weights_vs_time") for n in names)


def test_rows_without_a_start_epoch_count_days_from_the_first_batch(tmp_path):
    with RunStore(tmp_path) as store:
        store.save_weights("a", {"chi2": _history([0.5, 1.0], [0.3, 0.5])})
        store.save_weights("b", {"chi2": _history([0.7, 1.2], [0.2, 0.6])})
    (tmp_path / "runs.jsonl").write_text("".join(json.dumps(_row(r, "none", i, t0=False)) + "\n"
                                                 for i, r in enumerate("ab")))
    wh = C.weight_history(C.load_campaign(tmp_path), "chi2", "s", "v", points=8)  # grid step 0.1 day
    assert wh.origin == "first gating batch" and wh.days[-1] == pytest.approx(0.7)
    assert wh.median[0, 0, 0] == pytest.approx(0.3) and wh.median[0, 3, 0] == pytest.approx(0.25)

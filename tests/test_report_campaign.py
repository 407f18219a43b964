"""Campaign report on a hand-made runs.jsonl: scoring, statistics, figures, report.md."""

from __future__ import annotations

import json
import math
import struct

import numpy as np
import pytest

pytest.importorskip("matplotlib")
from scipy.stats import binomtest

from ground.report import campaign_data as C
from ground.report import campaign_plots
from ground.report.build import classify, report

FILTERS = ("radio", "optical", "fused")


def row(case: str, seed: int, weights, *, declared: bool, false_alarm: bool = False, cls: str = "none",
        latency_h: float | None = None, status: str = "ok", cell_as_text: bool = False, nested: bool = True,
        calibrated: bool = True) -> dict:
    """A runs.jsonl row as the campaign runner writes it (summary nested), or flat."""
    tc = {"none": "none", "optical": "optical-measurement", "radio": "radiometric-measurement"}[case.split("-")[0]]
    cell = {"scenario": "insight-approach", "fault": case, "variant": "default"}
    g = {"mean_weights": dict(zip(FILTERS, weights))}
    if tc != "none":
        g["mean_weights_after_onset"] = dict(zip(FILTERS, weights[::-1]))
    summary = {
        "fault": {"preset": None if case == "none" else case, "class": tc},
        "gating": {"chi2": g},
        "anomaly": {"declared": declared, "false_alarm": false_alarm, "class": cls if declared else "none",
                    "true_class": tc, "latency_s": None if latency_h is None else latency_h * 3600.0},
    }
    head = {"id": f"{case}-{seed}", "cell": " / ".join(cell.values()) if cell_as_text else cell, "seed": seed,
            "status": status, "fault_class": tc, "detector": {"network": "chi2", "calibrated": calibrated}}
    if status != "ok":
        return head | {"summary": None, "error": {"type": "RuntimeError", "message": "filter diverged\nat step 3"}}
    return head | ({"summary": summary} if nested else summary)


@pytest.fixture
def campaign_dir(tmp_path):
    rows = [
        row("none", 1, (0.3, 0.3, 0.4), declared=False, nested=False),
        # failed first, then re-run successfully: the later row of an id wins
        row("optical-bias-medium", 1, (0.0, 0.0, 1.0), declared=False, status="failed"),
        row("none", 2, (0.4, 0.3, 0.3), declared=True, false_alarm=True, cls="dynamics"),
        row("optical-bias-medium", 1, (0.9, 0.06, 0.04), declared=True, cls="optical-measurement", latency_h=2.0),
        row("optical-bias-medium", 2, (0.8, 0.1, 0.1), declared=True, cls="optical-measurement", latency_h=4.0, cell_as_text=True),
        row("optical-bias-medium", 3, (0.7, 0.2, 0.1), declared=True, cls="unknown", latency_h=9.0),
        row("optical-bias-small", 1, (0.4, 0.3, 0.3), declared=False),
        # declared before the onset: a false alarm, not a detection, even though a fault was injected
        row("optical-bias-small", 2, (0.5, 0.25, 0.25), declared=True, false_alarm=True, cls="optical-measurement"),
        row("radio-bias-large", 1, (0.3, 0.4, 0.3), declared=True, cls="radiometric-measurement", latency_h=30.0),
        row("radio-bias-large", 2, (0.3, 0.4, 0.3), declared=False, status="failed"),
        # no calibrated detector: weights count, detection statistics do not
        row("radio-bias-large", 3, (0.2, 0.6, 0.2), declared=False, calibrated=False),
    ]
    with open(tmp_path / "runs.jsonl", "w") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
        f.write('{"id": "cut-sh')  # a campaign still being written
    return tmp_path


def test_load_and_score(campaign_dir):
    camp = C.load_campaign(campaign_dir)
    assert len(camp.rows) == 9 and len(camp.failed) == 1 and camp.bad_lines == 1
    assert camp.failed[0]["id"] == "radio-bias-large-2"
    assert C.cases(camp.rows) == ["none", "optical-bias-small", "optical-bias-medium", "radio-bias-large"]
    stats = {s.case: s for s in C.case_stats(camp.rows)}
    med = stats["optical-bias-medium"]
    assert (med.n, med.detections, med.correct_class, med.false_alarms) == (3, 3, 2, 0)
    assert sorted(med.latencies_h) == [2.0, 4.0, 9.0]
    small = stats["optical-bias-small"]
    assert (small.n, small.detections, small.false_alarms) == (2, 0, 1)
    assert stats["none"].rate == pytest.approx(0.5)  # the nominal case reports its false-alarm rate
    assert stats["radio-bias-large"].n == 1  # the failed and the uncalibrated runs are left out


def test_interval_is_the_exact_binomial_one():
    for k, n in ((0, 8), (3, 8), (8, 8), (17, 40), (1, 1)):
        ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
        assert C.interval(k, n) == pytest.approx((ci.low, ci.high), abs=1e-9)
    assert all(math.isnan(x) for x in C.interval(0, 0))


def test_confusion_matrix_counts(campaign_dir):
    classes, mat = C.confusion(C.load_campaign(campaign_dir).rows)
    idx = {c: i for i, c in enumerate(classes)}
    assert mat.sum() == 8  # the uncalibrated run is not scored
    assert mat[idx["none"], idx["none"]] == 1 and mat[idx["none"], idx["dynamics"]] == 1
    opt = idx["optical-measurement"]
    assert mat[opt, opt] == 3 and mat[opt, idx["unknown"]] == 1 and mat[opt, idx["none"]] == 1
    assert mat[idx["radiometric-measurement"], idx["radiometric-measurement"]] == 1


def test_mean_weights_per_case(campaign_dir):
    rows = C.load_campaign(campaign_dir).rows
    mw = C.mean_weights(rows, "chi2", "default")
    assert mw.filters == list(FILTERS)
    i = mw.cases.index("optical-bias-medium")
    assert mw.mean[i] == pytest.approx([0.8, 0.12, 0.08])
    assert mw.std[i, 0] == pytest.approx(np.std([0.9, 0.8, 0.7]))
    after = C.mean_weights(rows, "chi2", "default", "mean_weights_after_onset")
    assert after.mean[after.cases.index("optical-bias-medium")] == pytest.approx([0.08, 0.12, 0.8])
    # nominal runs have no onset: their full-arc mean stands in
    assert after.mean[after.cases.index("none")] == pytest.approx([0.35, 0.3, 0.35])


def test_bar_heights_are_the_mean_weights(campaign_dir):
    rows = C.load_campaign(campaign_dir).rows
    mw = C.mean_weights(rows, "chi2", "default")
    fig = campaign_plots.plot_mean_weights(mw)
    heights = sorted(round(p.get_height(), 9) for p in fig.axes[0].patches)
    assert heights == sorted(round(v, 9) for v in mw.mean.ravel())
    labels = [t.get_text().split("\n")[0] for t in fig.axes[0].get_xticklabels()]
    assert labels == ["none", "optical-bias", "radio-bias"]  # small and medium share the optical-bias group


def test_campaign_report_files(campaign_dir):
    what = classify(campaign_dir)
    assert what.kind == "campaign" and what.default_out == campaign_dir / "report"
    paths = report(campaign_dir)
    names = {p.name for p in paths}
    assert names == {"mean_weights_chi2.png", "mean_weights_after_onset_chi2.png", "confusion_matrix.png",
                     "detection_latency.png", "detection_probability.png", "report.md"}
    for p in paths:
        if p.suffix == ".png":
            data = p.read_bytes()
            assert data[:8] == b"\x89PNG\r\n\x1a\n"
            w, h = struct.unpack(">II", data[16:24])
            assert 700 <= w <= 1400 and 200 <= h <= 1000, (p.name, w, h)
    md = (campaign_dir / "report" / "report.md").read_text()
    assert "9 successful runs, 1 failed, 1 unreadable lines" in md
    assert "1 runs had no calibrated detector" in md
    lo = 0.025 ** (1 / 3)  # Clopper–Pearson lower bound for 3 of 3: (alpha/2)^(1/n)
    assert f"| optical-bias-medium | optical-measurement | 3 | 1.00 [{lo:.2f}, 1.00] | 0/3 | 2/3 | 4.0 |" in md
    assert "| radio-bias-large-2 | insight-approach / radio-bias-large / default | failed | RuntimeError: filter diverged at step 3 |" in md
    assert "](confusion_matrix.png)" in md


def test_not_a_campaign(tmp_path):
    with pytest.raises(C.CampaignReadError):
        C.load_campaign(tmp_path)

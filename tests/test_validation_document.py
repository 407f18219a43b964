"""The validation report generator on synthetic campaign rows: the tables carry the papers' numbers
next to the means over seeds, and the detection table counts what the rows say."""

from __future__ import annotations

import json
from pathlib import Path

from campaign_rows import complete_row
from tools.validation import paper
from tools.validation.document import detection_section, render, table3_section

FILTERS = ("radio", "optical", "fused")


def _anomaly(declared: bool, true_class: str, *, latency_h: float | None = None, cls: str = "none",
             false_alarm: bool = False) -> dict:
    return {"detector": True, "declared": declared, "true_class": true_class, "class": cls, "first_class": cls,
            "network": "chi2", "false_alarm": false_alarm, "onset_true_day": None if true_class == "none" else 20.0,
            "latency_s": None if latency_h is None else latency_h * 3600.0}


def _row(i: int, case: str, seed: int, weights: dict, anomaly: dict, monitors: dict | None = None) -> dict:
    summary = {"gating": {"chi2": {"mean_weights": weights, "mean_weights_after_onset": weights},
                          "magill": {"mean_weights": {"radio": 0.0, "optical": 0.0, "fused": 1.0}}},
               "anomaly": anomaly}
    if monitors:
        summary["monitors"] = monitors
    return complete_row({"id": f"r{i:03d}", "cell": {"scenario": "insight-approach", "fault": case, "variant": "v"},
                         "seed": seed, "status": "ok", "summary": summary})


def _write(tmp_path: Path, rows: list[dict]) -> Path:
    camp = tmp_path / "camp"
    camp.mkdir()
    (camp / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return camp


def test_table3_section_puts_paper_and_seed_means_side_by_side(tmp_path):
    rows, i = [], 0
    for case in paper.TABLE3_CHI2:
        for seed, w in ((1, (0.30, 0.36, 0.34)), (2, (0.36, 0.30, 0.34))):
            rows.append(_row(i, case, seed, dict(zip(FILTERS, w)), _anomaly(False, "none")))
            i += 1
    sec = table3_section(_write(tmp_path, rows), [], tmp_path)
    text = "\n".join(sec.lines)
    # paper's medium optical row and our mean ± sample std over the two seeds: 0.33 ± 0.042
    assert "| medium bias - optical | 0.9008 | 0.0638 | 0.0354 | 0.330 ± 0.042 | 0.330 ± 0.042 | 0.340 ± 0.000 |" in text
    verdicts = {c.key: c.holds for c in sec.claims}
    assert verdicts["no-bias"] and verdicts["small-radio"] and not verdicts["medium-optical"]
    assert verdicts["magill-fused"]
    # the reading quotes the same runs' weights, not numbers written by hand
    assert "medium 0.330 / 0.330 / 0.340 against 0.9008 / 0.0638 / 0.0354" in " ".join(sec.discussion.split())
    doc = render([sec], generated="today", commands=["navbank campaign lubey-ely-table3"])
    assert "| Lubey & Ely 2022 Table 3 | medium optical bias: radio > 0.8 and fused lowest | **no** |" in doc


def test_detection_section_counts_detections_false_alarms_and_classes(tmp_path):
    w = dict(zip(FILTERS, (1 / 3, 1 / 3, 1 / 3)))
    rows, i = [], 0
    for seed in range(1, 5):  # nominal: one false alarm on chi2, none on magill
        a = _anomaly(seed == 1, "none", cls="unknown")
        rows.append(_row(i, "none", seed, w, a, {"magill": _anomaly(False, "none")}))
        i += 1
    for seed in range(1, 5):  # optical bias: chi2 detects 3 (2 classified right), magill 1
        a = _anomaly(seed <= 3, "optical-measurement", latency_h=10.0 * seed,
                     cls="optical-measurement" if seed <= 2 else "unknown")
        m = _anomaly(seed == 1, "optical-measurement", latency_h=50.0, cls="radiometric-measurement")
        rows.append(_row(i, "optical-bias-medium", seed, w, a, {"magill": m, "chi2-two-sided": {"error": {"type": "FdirInputError", "message": "boom"}}}))
        i += 1
    sec = detection_section(_write(tmp_path, rows), [], tmp_path)
    text = "\n".join(sec.lines)
    assert "| none | FA 1/4 [1–81 %] | FA 0/4 [0–60 %] |" in text
    assert "| optical-bias-medium | 3/4 [19–99 %], 20 h (p90 28 h), class 2/3 | 1/4 [1–81 %], 50 h (p90 50 h), class 0/1 |" in text
    assert "| fault preset | chi2 | magill |" in text  # the failed chi2-two-sided replay is not scored
    # confusion rows: injected optical-measurement on chi2 -> 2 optical, 1 unknown, 1 none
    chi2_block = text.split("Characterization, chi2 ")[1].split("Characterization")[0]
    assert "| optical-measurement | 1 | 2 | 0 | 0 | 1 |" in chi2_block


def test_table3_batch_statistics_are_medians_of_run_means(tmp_path):
    """The G table: per case and filter, the median over runs of each run's mean per-batch G, the
    closing partial batch left out (recomputed here from the arrays written)."""
    import numpy as np

    from ground.report.run_weights import RunWeights
    from tools.validation.document import batch_statistics

    rows = [_row(i, "no bias", i + 1, dict(zip(FILTERS, (1 / 3,) * 3)), _anomaly(False, "none")) for i in range(3)]
    camp = _write(tmp_path, rows)
    rng = np.random.default_rng(3)
    means = []
    for r in rows:
        stat = rng.uniform(900, 1300, size=(6, 3))
        stat[-1] = 1e6  # the closing tail must not count
        means.append(stat[:-1].mean(axis=0))
        w = RunWeights(filters=FILTERS, t_s=np.arange(6.0), batch=np.arange(6), weights=np.full((6, 3), 1 / 3),
                       statistic=stat)
        (camp / "weights" / "chi2").mkdir(parents=True, exist_ok=True)
        w.save(camp / "weights" / "chi2" / f"{r['id']}.npz")
    from tools.validation.tables import ok_rows

    lines = batch_statistics(camp, ok_rows(camp), ("no bias", "large bias - optical"))
    med = np.median(means, axis=0)
    assert lines[2] == "| no bias | 3 | " + " | ".join(f"{g:,.0f}" for g in med) + " |"
    assert len(lines) == 3  # no row for a case without runs


def test_shipped_detector_replay_needs_stored_weights_and_declares_on_a_departure(tmp_path):
    import numpy as np

    from ground.report.run_weights import RunWeights
    from tools.scenario import load_scenario
    from tools.validation.document import shipped_detector_verdicts
    from tools.validation.tables import ok_rows

    rows = [_row(i, "no bias", i + 1, dict(zip(FILTERS, (1 / 3,) * 3)), _anomaly(False, "none")) for i in range(2)]
    camp = _write(tmp_path, rows)
    assert shipped_detector_verdicts(camp, "insight-approach", ok_rows(camp)) is None  # no weights kept
    cal = load_scenario("insight-approach").fsw.detector.calibration
    nominal = np.tile(cal.nominal_mean, (30, 1))
    biased = nominal.copy()
    biased[10:] = (0.9, 0.05, 0.05)  # the radio-only filter takes the weight: an optical fault
    (camp / "weights" / "chi2").mkdir(parents=True)
    for r, w in zip(rows, (nominal, biased)):
        RunWeights(filters=FILTERS, t_s=np.arange(30.0) * 1e5, batch=np.arange(30), weights=w).save(
            camp / "weights" / "chi2" / f"{r['id']}.npz")
    assert shipped_detector_verdicts(camp, "insight-approach", ok_rows(camp)) == [None, "optical-measurement"]

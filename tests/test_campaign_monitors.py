"""Monitors: several detectors evaluated on the same campaign runs (plan, worker replay, statistics)."""

from __future__ import annotations

import json

import pytest

from fsw.core import stamp
from fsw.fdir.config import DetectorConfig, config_to_yaml
from fsw.interface import messages as m
from fsw.interface.yamlconfig import ConfigError
from tools.campaign.plan import expand
from tools.campaign.plan_file import PlanFile
from tools.campaign.report import render
from tools.campaign.spec import load_campaign, load_campaign_text
from tools.campaign.stats import compute
from tools.campaign.worker import execute
from campaign_rows import complete_row
from ground.report.row_types import ResultRow
from ground.report.run_facts import anomaly_summary

FILTERS = ("radio", "optical", "fused")
DAY = 86400.0

CAMPAIGN = """\
name: mon
seeds: {count: 1, base: 1}
onset_day: 1.0
matrix:
  - scenarios: [short.yaml]
    faults: [none, optical-bias-medium]
    networks:
      - name: three
        detector: chi2
        calibration: det-chi2.yaml
        monitors: {chi2: det-chi2.yaml, chi2-two-sided: det-chi2-two-sided.yaml, magill: det-magill.yaml}
"""


def _calibration(network: str, threshold: float = 8.0) -> DetectorConfig:
    # a tight band around equal weights: 2 of 3 batches beyond 8 sigma declare
    return DetectorConfig(network=network, filters=FILTERS, nominal_mean=(1 / 3,) * 3,
                          nominal_cov=tuple(tuple(1e-5 * (i == j) for j in range(3)) for i in range(3)),
                          threshold=threshold, clear_threshold=4.0, onset_reference=2.0, persistence_k=2,
                          persistence_n=3, hold=3)


def _write(tmp_path, short_scenario, campaign: str = CAMPAIGN):
    (tmp_path / "short.yaml").write_text(short_scenario(gating=("{network: chi2, batch_size: 100}",)))
    for net in ("chi2", "chi2-two-sided", "magill"):
        (tmp_path / f"det-{net}.yaml").write_text(config_to_yaml(_calibration(net)))
    (tmp_path / "c.yaml").write_text(campaign)
    return tmp_path / "c.yaml"


# -- the anomaly block, one definition for the onboard detector and the monitors -----------------

def _report(t, flag, cls="none", onset=None, declared=None, conf=0.0):
    return m.AnomalyReport(t_s=t, timestamp=stamp(t), flag=flag, anomaly_class=cls, confidence=conf, onset_s=onset,
                           declared_s=declared, network="n")


def test_anomaly_block_by_hand():
    t0, onset = 1000.0, 1000.0 + 2 * DAY
    reps = [_report(t0, False), _report(t0 + 2.5 * DAY, True, "unknown", t0 + 2.1 * DAY, t0 + 2.5 * DAY, 0.4),
            _report(t0 + 3 * DAY, True, "optical-measurement", t0 + 2.1 * DAY, t0 + 2.5 * DAY, 0.9),
            _report(t0 + 4 * DAY, False, "none")]
    a = anomaly_summary(reps, onset_true=onset, true_class="optical-measurement", t0=t0).to_json()
    assert a["declared"] and not a["false_alarm"] and a["detector"]
    assert a["time_day"] == pytest.approx(2.5) and a["latency_s"] == pytest.approx(0.5 * DAY)
    assert a["class"] == "optical-measurement" and a["first_class"] == "unknown" and a["correct_class"]
    assert a["confidence"] == 0.9 and a["onset_estimate"] == t0 + 2.1 * DAY
    assert not a["final_flag"] and a["final_class"] == "none"
    early = anomaly_summary(reps, onset_true=t0 + 3 * DAY, true_class="optical-measurement", t0=t0).to_json()
    assert early["false_alarm"] and early["latency_s"] is None
    nominal = anomaly_summary(reps, onset_true=None, true_class="none", t0=t0).to_json()
    assert nominal["false_alarm"] and not nominal["correct_class"]
    quiet = anomaly_summary([], onset_true=None, true_class="none", t0=t0).to_json()
    assert not quiet["detector"] and not quiet["declared"] and quiet["class"] == "none"


# -- the plan -----------------------------------------------------------------------------------

def test_monitored_networks_join_the_gating_list_and_the_task(tmp_path, short_scenario):
    plan = expand(load_campaign(str(_write(tmp_path, short_scenario))))
    assert len(plan.tasks) == 2
    for t in plan.tasks:
        assert [g["network"] for g in t.scenario["fsw"]["gating"]] == ["chi2", "chi2-two-sided", "magill"]
        assert t.detector.to_json() == {"network": "chi2", "calibrated": True,
                                        "monitors": ["chi2", "chi2-two-sided", "magill"]}
        assert {n: c["network"] for n, c in t.monitors.items()} == {n: n for n in t.monitors}
        assert t.monitors["magill"]["threshold"] == 8.0
    assert plan.plan_file().to_json()["cells"][0]["detector"]["monitors"] == ["chi2", "chi2-two-sided", "magill"]
    # monitors change the summary, not the flight: the same cell without them is another run id
    bare = expand(load_campaign(str(_write(tmp_path, short_scenario, CAMPAIGN.replace(
        "        monitors: {chi2: det-chi2.yaml, chi2-two-sided: det-chi2-two-sided.yaml, magill: det-magill.yaml}\n",
        "        gating: [{network: chi2, batch_size: 100}, {network: chi2-two-sided}, {network: magill}]\n")))))
    assert [t.scenario for t in bare.tasks] == [t.scenario for t in plan.tasks]
    assert {t.id for t in bare.tasks}.isdisjoint({t.id for t in plan.tasks})


def test_monitor_calibration_of_another_network_or_bank_is_one_line(tmp_path, short_scenario):
    path = _write(tmp_path, short_scenario, CAMPAIGN.replace("magill: det-magill.yaml", "magill: det-chi2.yaml"))
    with pytest.raises(ConfigError) as exc:
        expand(load_campaign(str(path)))
    assert "monitors.magill" in str(exc.value) and "'chi2'" in str(exc.value)
    other = DetectorConfig(**{**_calibration("magill").__dict__, "filters": ("a", "b", "c")})
    (tmp_path / "det-magill.yaml").write_text(config_to_yaml(other))
    path.write_text(CAMPAIGN)
    with pytest.raises(ConfigError, match="bank"):
        expand(load_campaign(str(path)))


def test_detection_matrix_carries_three_detectors_on_one_run(tmp_path):
    from importlib import resources

    from sim.faults.presets import FAULT_PRESETS

    text = resources.files("tools").joinpath("campaigns/detection-matrix.yaml").read_text()
    (tmp_path / "detectors").mkdir()
    for net in ("chi2", "chi2-two-sided", "magill"):
        (tmp_path / "detectors" / f"detector-{net}.yaml").write_text(config_to_yaml(_calibration(net)))
    dm = expand(load_campaign_text(text, "detection-matrix.yaml", tmp_path))
    assert {t.cell.fault for t in dm.tasks} == set(FAULT_PRESETS) and len(dm.tasks) == len(FAULT_PRESETS) * 100
    t = dm.tasks[0]
    assert {t.cell.variant for t in dm.tasks} == {"all-networks"}
    assert t.detector_network == "chi2" and t.detector_calibrated
    assert sorted(t.monitors) == ["chi2-two-sided", "magill"]
    assert sorted(t.extract_weights) == ["chi2", "chi2-two-sided", "magill"]
    assert [g["network"] for g in t.scenario["fsw"]["gating"]] == ["chi2", "magill", "chi2-two-sided"]


# -- the worker: replay equals the onboard detector ---------------------------------------------

def test_replayed_detector_equals_the_onboard_one_on_a_real_run(tmp_path, short_scenario):
    plan = expand(load_campaign(str(_write(tmp_path, short_scenario))))
    task = next(t for t in plan.tasks if t.cell.fault == "optical-bias-medium")
    row = execute(task).row
    assert row.status == "ok", row.error
    s = row.summary
    onboard, replayed = s.anomaly, s.monitors["chi2"].anomaly
    assert onboard.declared and not onboard.false_alarm and onboard.correct_class
    # the declaration epoch is the end of the frame that ran the declaring gating batch, not the
    # batch's own epoch: equality here checks the replay's dating, too
    assert replayed == onboard
    monitors = s.to_json()["monitors"]
    assert json.loads(json.dumps(monitors)) == monitors  # plain data for runs.jsonl
    for net in ("chi2-two-sided", "magill"):
        assert set(monitors[net]) >= set(onboard.to_json()) - {"first_class", "latency_day"}
        assert s.monitors[net].anomaly.network == net and s.monitors[net].anomaly.detector


LAGGING = """\
name: lag
seed: 2
sim:
  trajectory: {span_days: 2.0}
  faults:
    - {type: optical-bias, onset_day: 1.0, sample_px: 20.0, line_px: 30.0}
fsw:
  budget: {mode: work-units, work_unit_budget: 15.0}
  gating:
    - {network: chi2, batch_size: 100}
"""


def test_replayed_declarations_are_dated_as_onboard_when_the_gating_lags():
    """A starved budget makes the gating run hours after its data. Onboard, a declaration is
    dated by the end of the frame that made it; the replay must date every declaration alike."""
    import dataclasses

    from tools.campaign.worker import replay_detector
    from tools.inprocess import run_in_process
    from tools.scenario import load_text_scenario

    cal = _calibration("chi2")
    cfg = load_text_scenario(LAGGING)
    cfg = dataclasses.replace(cfg, fsw=dataclasses.replace(
        cfg.fsw, detector=dataclasses.replace(cfg.fsw.detector, network="chi2", calibration=cal)))
    result = run_in_process(cfg)
    onboard = [r for r in result.topic("fsw/anomaly") if r.flag]
    replayed = replay_detector(result.messages, cal, result.config.fsw.families(), result.summary.t0)
    assert all(isinstance(r, m.AnomalyReport) for r in replayed)
    flagged = [r for r in replayed if r.flag]
    assert onboard and flagged
    # the first onboard report of a declaration is dated by its batch; the lag is many frames
    assert onboard[0].declared_s - onboard[0].t_s > 10 * cfg.fsw.budget.frame_s
    assert flagged[0].declared_s == onboard[0].declared_s
    assert {r.declared_s for r in flagged} == {r.declared_s for r in onboard}
    a = result.summary.anomaly
    assert anomaly_summary(replayed, onset_true=a.onset_true, true_class=a.true_class, t0=result.summary.t0) == a


# -- statistics per detector --------------------------------------------------------------------

OPT = "optical-measurement"


def _anomaly(declared, cls="none", true_class="none", latency_h=None, false_alarm=False, time_day=None):
    return {"declared": declared, "class": cls if declared else "none", "true_class": true_class,
            "latency_s": None if latency_h is None else latency_h * 3600.0, "false_alarm": false_alarm,
            "time_day": time_day, "correct_class": (cls == true_class) if declared else None}


def _mrow(rid, fault, seed, onboard, monitors, *, status="ok"):
    tc = OPT if fault != "none" else "none"
    summary = {"filters": list(FILTERS),
               "gating": {"chi2": {"mean_weights": dict(zip(FILTERS, (0.5, 0.25, 0.25)))}},
               "anomaly": onboard, "monitors": monitors, "position_error_rms_km": {"radio": 1.0},
               "budget": {"max_utilisation": 0.5, "overruns": 0, "final_backlog": 0, "max_backlog": 0}}
    return complete_row({"id": rid, "cell": {"scenario": "s", "fault": fault, "variant": "v"}, "seed": seed, "fault_class": tc,
            "detector": {"network": "chi2", "calibrated": True, "monitors": ["magill"]}, "span_days": 10.0,
            "status": status, "summary": summary if status == "ok" else None,
            "error": None if status == "ok" else {"type": "ValueError", "message": "boom"}, "wall_time_s": 1.0})


def _mrows():
    return [
        _mrow("n1", "none", 1, _anomaly(False), {"magill": _anomaly(True, "unknown", false_alarm=True, time_day=2.0)}),
        _mrow("n2", "none", 2, _anomaly(False), {"magill": _anomaly(False)}),
        _mrow("o1", "ob", 1, _anomaly(True, OPT, OPT, 2.0), {"magill": _anomaly(False, true_class=OPT)}),
        _mrow("o2", "ob", 2, _anomaly(True, OPT, OPT, 4.0), {"magill": _anomaly(True, "unknown", OPT, 1.0)}),
        _mrow("o3", "ob", 3, _anomaly(False, true_class=OPT), {"magill": {"error": {"type": "FdirInputError",
                                                                                      "message": "NaN"}}}),
        _mrow("o4", "ob", 4, None, {}, status="failed"),
    ]


def test_every_detector_is_its_own_variant_in_the_statistics():
    plan = {"name": "p", "cells": [
        {"scenario": "s", "fault": f, "variant": "v", "key": f"s / {f} / v", "fault_class": c,
         "detector": {"network": "chi2", "calibrated": True, "monitors": ["magill"]}}
        for f, c in (("none", "none"), ("ob", OPT))],
        "runs": [{"id": i, "cell": f"s / {f} / v", "seed": 1} for i, f in
                 (("n1", "none"), ("n2", "none"), ("o1", "ob"), ("o2", "ob"), ("o3", "ob"), ("o4", "ob"),
                  ("o5", "ob"))]}
    stats = compute([ResultRow.from_json(r) for r in _mrows()], PlanFile.from_json(plan))
    s = stats.to_json()
    cells = {(c["fault"], c["variant"]): c for c in s["cells"]}
    assert list(cells) == [("none", "v / chi2"), ("none", "v / magill"), ("ob", "v / chi2"), ("ob", "v / magill")]
    chi2, mag = cells[("ob", "v / chi2")], cells[("ob", "v / magill")]
    assert chi2["detection"]["k"] == 2 and chi2["detection"]["n"] == 3 and chi2["latency"]["median_h"] == 3.0
    # magill: o1 missed, o2 detected (wrong class), o3's monitor failed -> a failed run of that detector
    assert mag["detection"]["k"] == 1 and mag["detection"]["n"] == 2 and mag["characterization"]["k"] == 0
    assert mag["runs"] == {"planned": 5, "ok": 2, "failed": 2, "missing": 1} and mag["monitor"]
    assert chi2["runs"] == {"planned": 5, "ok": 3, "failed": 1, "missing": 1} and not chi2["monitor"]
    assert mag["detector"] == {"network": "magill", "calibrated": True}
    assert cells[("none", "v / magill")]["false_alarm"]["per_run"]["k"] == 1
    assert cells[("none", "v / chi2")]["false_alarm"]["per_run"]["k"] == 0
    assert cells[("none", "v / magill")]["false_alarm"]["per_day"]["exposure_days"] == pytest.approx(12.0)
    assert s["runs"]["ok"] == 5 and s["runs"]["failed"] == 1 and s["runs"]["missing"] == 1
    conf = {g["variant"]: g for g in s["confusion"]}
    assert conf["v / magill"]["matrix"][OPT] == {"none": 1, OPT: 0, "unknown": 1}
    assert conf["v / chi2"]["matrix"][OPT]["none"] == 1 and conf["v / chi2"]["matrix"][OPT][OPT] == 2
    (table,) = s["weight_tables"]  # the runs' weights once, under the real variant
    assert table["variant"] == "v" and [r["case"] for r in table["rows"]] == ["none", "ob"]
    md = render(stats)
    assert "## Detectors side by side" in md and "| fault | chi2 | magill |" in md
    assert "| ob | 2/3 66.7 % [9, 99] | 1/2 50.0 % [1, 99] |" in md
    assert "| none | FA 0/2 0.0 % [0, 84]; 0/day | FA 1/2 50.0 % [1, 99]; 0.0833/day |" in md
    assert md.count("| s / ob / v / chi2 | 1 | 5 | 4 |") == 0  # position rows only for the real cells
    assert md.count("ValueError: boom") == 1 and md.count("FdirInputError: NaN") == 1


def test_ground_report_scores_each_network_and_draws_them_side_by_side(tmp_path):
    pytest.importorskip("matplotlib")
    from ground.report import campaign_data as C
    from ground.report.campaign_plots import plot_detectors_compared, write_campaign_figures

    with open(tmp_path / "runs.jsonl", "w") as f:
        for r in _mrows():
            f.write(json.dumps(r) + "\n")
    camp = C.load_campaign(tmp_path)
    stats = {(st.case, st.detector): st for st in C.case_stats(camp.rows)}
    assert (stats[("ob", "chi2")].n, stats[("ob", "chi2")].detections) == (3, 2)
    assert (stats[("ob", "magill")].n, stats[("ob", "magill")].detections) == (2, 1)  # the failed monitor is out
    assert stats[("none", "magill")].false_alarms == 1 and stats[("ob", "magill")].variant == "v / magill"
    assert C.detector_variants(camp.rows) == ["v / chi2", "v / magill"]
    classes, mat = C.confusion(camp.rows, "v / magill")
    assert mat[classes.index(OPT), classes.index("unknown")] == 1 and mat.sum() == 4
    assert len(C.mean_weights(camp.rows, "chi2", "v").cases) == 2  # weights still once per run
    confusions = {v: C.confusion(camp.rows, v) for v in C.detector_variants(camp.rows)}
    fig = plot_detectors_compared(C.case_stats(camp.rows), confusions)
    bars = fig.axes[0].patches
    heights = sorted(round(p.get_height(), 9) for p in bars if p.get_width() < 1.0)
    assert heights == sorted(round(st.rate, 9) for st in stats.values())
    names = {p.name for p in write_campaign_figures(camp, tmp_path / "fig")}
    assert "networks_compared.png" in names and "confusion_matrix.png" not in names

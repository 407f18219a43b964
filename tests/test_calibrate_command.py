"""`navbank calibrate`: nominal runs through the campaign machinery, weight histories, detector YAML."""

import dataclasses
import json

import numpy as np
import pytest

from fsw.fdir.config import DetectorConfig
from fsw.interface.yamlconfig import load_file
from tools.campaign.plan import expand
from tools.campaign.store import load_weights, read_rows
from tools.cli import main
from tools.commands.calibrate import nominal_campaign
from tools.scenario import ScenarioConfig, load_scenario


def _scenario(short_scenario, *more_gating: str) -> str:
    # a fault the nominal calibration runs must drop, and a Magill detector they must not keep
    return short_scenario(faults=("{type: optical-bias, onset_day: 1.0, sample_px: 2.0, line_px: 3.0}",),
                          gating=("{network: magill}", *more_gating), detector="magill")


def test_nominal_plan_has_no_fault_no_detector_and_the_network(tmp_path, short_scenario, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "short.yaml").write_text(_scenario(short_scenario))
    plan = expand(nominal_campaign("short.yaml", "chi2", 4, 1001), extract_weights="chi2")
    assert [t.seed for t in plan.tasks] == [1001, 1002, 1003, 1004]
    for t in plan.tasks:
        assert t.scenario["sim"]["faults"] == [] and t.fault_class == "none"
        assert t.scenario["fsw"]["detector"]["calibration"] is None
        assert t.scenario["fsw"]["detector"]["network"] == "chi2"
        assert [g["network"] for g in t.scenario["fsw"]["gating"]] == ["magill", "chi2"]
        assert t.extract_weights == ("chi2",)


@pytest.mark.slow
def test_calibrate_writes_detector_and_scenario(tmp_path, short_scenario, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "short.yaml").write_text(_scenario(short_scenario, "{network: chi2, batch_size: 200}"))
    args = ["calibrate", "--scenario", "short.yaml", "--network", "chi2", "--seeds", "10", "--target-fa", "0.1",
            "--workers", "2", "--out", "det.yaml", "--write-scenario", "cal.yaml", "--runs-dir", "runs", "--quiet"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "threshold" in printed and "achieved FA" in printed and "10 nominal runs" in printed
    det = load_file(DetectorConfig, tmp_path / "det.yaml")
    assert det.network == "chi2" and det.filters == ("radio", "optical", "fused") and det.target_fa == 0.1
    assert f"{det.threshold:.6g}" in printed
    scen = load_file(ScenarioConfig, tmp_path / "cal.yaml")
    assert scen.fsw.detector.network == "chi2" and scen.fsw.detector.calibration == det
    assert scen.sim.faults == load_scenario("short.yaml").sim.faults  # only fsw.detector changes
    assert "reproduce: navbank calibrate --scenario short.yaml --network chi2 --seeds 10" in (tmp_path / "cal.yaml").read_text()

    # the stored history is the FSW's chi2 weight telemetry of that run: it gives back the summary's
    # batch count, full-arc mean and final weights, which were computed from the run's messages
    rows = read_rows(tmp_path / "runs" / "runs.jsonl").rows
    assert len(rows) == 10 and all(r.status == "ok" for r in rows)
    for r in rows:
        stored = load_weights(tmp_path / "runs", r.id, "chi2")
        chi2 = r.summary.gating["chi2"]
        assert stored.weights.shape == (chi2.updates, 3) and chi2.updates >= 5
        np.testing.assert_allclose(stored.weights.mean(axis=0), list(chi2.mean_weights.values()), rtol=1e-12)
        np.testing.assert_array_equal(stored.weights[-1], list(chi2.final_weights.values()))
        assert np.all(np.diff(stored.t_s) > 0) and list(stored.batch) == list(range(chi2.updates))

    # nominal weights sit near 1/N and the nominal band was learned from them
    pooled = np.concatenate([load_weights(tmp_path / "runs", r.id, "chi2").weights for r in rows])
    np.testing.assert_allclose(det.nominal_mean, pooled.mean(axis=0), rtol=1e-12)

    # again: the runs are reused, nothing is flown, the same calibration comes out
    assert main(args) == 0
    assert len(read_rows(tmp_path / "runs" / "runs.jsonl").rows) == 10
    assert load_file(DetectorConfig, tmp_path / "det.yaml") == det


def test_calibrate_rejects_bad_arguments(capsys):
    assert main(["calibrate", "--seeds", "0"]) == 2
    assert main(["calibrate", "--target-fa", "1.5"]) == 2
    assert main(["calibrate", "--scenario", "no-such-scenario", "--seeds", "2"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 3


def test_builtin_plan_and_command_line_overrides(tmp_path):
    from tools.calibration.plan import load_plan
    from tools.commands.calibrate import PROCEDURE_DEFAULTS, resolve_plan
    from tools.cli import build_parser

    plan = load_plan("insight-approach")
    assert plan.networks == ("chi2", "chi2-two-sided", "magill") and plan.seeds >= 1000 and plan.holdout >= 300
    assert not set(plan.calibration_seeds()) & set(plan.holdout_seeds())
    parse = build_parser().parse_args
    assert resolve_plan(parse(["calibrate", "--plan", "insight-approach"])) == plan
    got = resolve_plan(parse(["calibrate", "--plan", "insight-approach", "--seeds", "7", "--network", "chi2"]))
    assert got == dataclasses.replace(plan, seeds=7, networks=("chi2",))
    assert resolve_plan(parse(["calibrate"])) == PROCEDURE_DEFAULTS


def test_bad_plans_are_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("scenario: insight-approach\nnetworks: [chi2]\nseeds: 10\nbase_seed: 1\ntarget_fa: 0.05\n"
                   "holdout: 5\nholdout_base_seed: 8\n")
    assert main(["calibrate", "--plan", str(bad)]) == 2
    assert main(["calibrate", "--plan", "no-such-plan"]) == 2
    assert main(["calibrate", "--plan", "insight-approach", "--holdout-base-seed", "1500"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and "overlap" in err[0] and "no-such-plan" in err[1] and "overlap" in err[2]


def test_several_networks_share_one_set_of_nominal_runs(tmp_path, short_scenario, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "short.yaml").write_text(_scenario(short_scenario))
    plan = expand(nominal_campaign("short.yaml", ["chi2", "chi2-two-sided", "magill"], 2, 1001))
    for t in plan.tasks:
        assert [g["network"] for g in t.scenario["fsw"]["gating"]] == ["magill", "chi2", "chi2-two-sided"]
        assert t.extract_weights == ("chi2", "chi2-two-sided", "magill")
        assert t.scenario["fsw"]["detector"]["calibration"] is None


@pytest.mark.slow
def test_calibrate_several_networks_to_a_directory(tmp_path, short_scenario, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "short.yaml").write_text(_scenario(short_scenario, "{network: chi2, batch_size: 200}"))
    args = ["calibrate", "--scenario", "short.yaml", "--network", "chi2", "--network", "magill", "--seeds", "4",
            "--target-fa", "0.2", "--workers", "2", "--out-dir", "dets", "--runs-dir", "runs", "--quiet"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "network chi2" in printed and "network magill" in printed
    rows = read_rows(tmp_path / "runs" / "runs.jsonl").rows
    assert len(rows) == 4  # one set of runs for both networks
    for net in ("chi2", "magill"):
        det = load_file(DetectorConfig, tmp_path / "dets" / f"detector-{net}.yaml")
        assert det.network == net
        pooled = np.concatenate([load_weights(tmp_path / "runs", r.id, net).weights for r in rows])
        np.testing.assert_allclose(det.nominal_mean, pooled.mean(axis=0), rtol=1e-12)
        assert f"--network {net}" in (tmp_path / "dets" / f"detector-{net}.yaml").read_text()
    assert main(["calibrate", "--scenario", "short.yaml", "--network", "chi2", "--network", "magill",
                 "--out", "x.yaml"]) == 2


@pytest.mark.slow
def test_calibrate_with_held_out_runs_and_report(tmp_path, short_scenario, monkeypatch, capsys):
    """--holdout flies disjoint seeds into RUNS/holdout and checks each detector on them; the JSON
    report's counts are recomputed here from the stored held-out weights with the detector."""
    from fsw.fdir.detector import AnomalyDetector
    from tools.calibration.record import read_record

    monkeypatch.chdir(tmp_path)
    (tmp_path / "short.yaml").write_text(_scenario(short_scenario, "{network: chi2, batch_size: 200}"))
    args = ["calibrate", "--scenario", "short.yaml", "--network", "chi2", "--network", "magill", "--seeds", "6",
            "--holdout", "4", "--target-fa", "0.3", "--workers", "2", "--out-dir", "dets", "--runs-dir", "runs",
            "--report", "cal.json", "--quiet"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert printed.count("held out") == 2
    held_rows = read_rows(tmp_path / "runs" / "holdout" / "runs.jsonl").rows
    assert sorted(r.seed for r in held_rows) == [1007, 1008, 1009, 1010]
    assert len(read_rows(tmp_path / "runs" / "runs.jsonl").rows) == 6
    rec = read_record(tmp_path / "cal.json")
    assert rec.plan.holdout == 4 and [n.network for n in rec.networks] == ["chi2", "magill"]
    families = load_scenario("short.yaml").fsw.families()
    for n in rec.networks:
        det = load_file(DetectorConfig, tmp_path / "dets" / f"detector-{n.network}.yaml")
        assert n.report.threshold == det.threshold and n.runs == 6 and n.holdout_runs == 4
        alarms = 0
        for r in held_rows:
            w = load_weights(tmp_path / "runs" / "holdout", r.id, n.network).weights
            d = AnomalyDetector(det, families)
            alarms += any(d.update(float(i), x, det.filters).flag for i, x in enumerate(w))
        assert n.holdout.units == 4 and n.holdout.false_alarms == alarms
        assert f"{n.holdout.false_alarms}/4" in printed
    assert json.loads((tmp_path / "cal.json").read_text())["plan"]["seeds"] == 6


@pytest.mark.parametrize("name", ["insight-approach", "insight-thrusters", "insight-process-noise"])
def test_shipped_detectors_come_from_their_plans(name):
    """Every shipped threshold names the plan that re-derives it, and agrees with it on the
    procedure; insight-approach's onboard detector is the shipped detector-chi2.yaml."""
    from importlib import resources

    from tools.calibration.plan import load_plan

    plan = load_plan(name)
    scen_text = resources.files("tools").joinpath("scenarios", f"{name}.yaml").read_text(encoding="utf-8")
    assert f"navbank calibrate --plan {name}" in scen_text and f"on {plan.seeds} nominal runs" in scen_text
    onboard = load_scenario(name).fsw.detector.calibration
    assert onboard.network in plan.networks and onboard.target_fa == plan.target_fa
    assert (onboard.persistence_k, onboard.persistence_n) == tuple(plan.persistence) and onboard.hold == plan.hold
    if name == "insight-approach":
        det_dir = resources.files("tools").joinpath("campaigns", "detectors")
        for net in plan.networks:
            text = det_dir.joinpath(f"detector-{net}.yaml").read_text(encoding="utf-8")
            assert f"--seeds {plan.seeds} --base-seed {plan.base_seed} --target-fa {plan.target_fa:g}" in text
        assert onboard == load_file(DetectorConfig, str(det_dir.joinpath("detector-chi2.yaml")))

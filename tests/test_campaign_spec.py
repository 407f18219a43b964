"""Campaign files: validation with file:line errors, expansion into runs, stable run ids, built-ins."""

from pathlib import Path

import pytest

from fsw.interface.yamlconfig import ConfigError
from tools.campaign.plan import expand, merge, run_id
from tools.campaign.spec import builtin_names, load_campaign
from tools.cli import main

CAMPAIGN = """\
name: t
seeds: {count: 2, base: 5}
onset_day: 1.5
overrides:
  fsw.budget.mode: work-units
matrix:
  - scenarios: [short.yaml]
    faults:
      - none
      - optical-bias-small
      - {preset: optical-bias-large, onset_day: 2.0}
      - name: range-100m
        faults: [{type: range-bias, onset_day: 1.0, range_m: 100.0}]
    networks:
      - default
      - chi2-two-sided
      - name: sw0.1
        params: {chi2: {sigma_w: 0.1}}
"""


def _write(tmp_path: Path, short_scenario, campaign: str = CAMPAIGN) -> Path:
    (tmp_path / "short.yaml").write_text(short_scenario(3.0, work_units=False))
    p = tmp_path / "c.yaml"
    p.write_text(campaign)
    return p


def test_expansion_cells_seeds_and_resolved_configs(tmp_path, short_scenario):
    plan = expand(load_campaign(str(_write(tmp_path, short_scenario))))
    assert len(plan.cells) == 4 * 3 and len(plan.tasks) == 4 * 3 * 2
    assert [t.seed for t in plan.tasks[:2]] == [5, 6]
    by = {(t.cell.fault, t.cell.variant, t.seed): t for t in plan.tasks}
    t = by[("optical-bias-large", "default", 5)]
    faults = t.scenario["sim"]["faults"]
    assert faults[0]["type"] == "optical-bias" and faults[0]["onset_day"] == 2.0 and faults[0]["sample_px"] == 20.0
    assert by[("optical-bias-small", "default", 5)].scenario["sim"]["faults"][0]["onset_day"] == 1.5
    assert by[("none", "default", 5)].scenario["sim"]["faults"] == [] and by[("none", "default", 5)].fault_class == "none"
    assert by[("range-100m", "default", 5)].fault_class == "radiometric-measurement"
    assert t.scenario["fsw"]["budget"]["mode"] == "work-units"
    assert t.scenario["sim"]["trajectory"]["span_days"] == 3.0 and t.span_days == 3.0
    # the shorthand variant adds its network and puts the detector on it
    two = by[("none", "chi2-two-sided", 5)].scenario["fsw"]
    assert [g["network"] for g in two["gating"]] == ["chi2", "magill", "chi2-two-sided"]
    assert two["detector"]["network"] == "chi2-two-sided"
    chi2 = next(g for g in by[("none", "sw0.1", 5)].scenario["fsw"]["gating"] if g["network"] == "chi2")
    assert chi2["sigma_w"] == 0.1 and chi2["batch_size"] == 200
    assert not t.detector_calibrated  # the scenario carries no calibration


def test_run_ids_are_stable_and_follow_the_configuration(tmp_path, short_scenario):
    p = _write(tmp_path, short_scenario)
    ids1 = [t.id for t in expand(load_campaign(str(p))).tasks]
    ids2 = [t.id for t in expand(load_campaign(str(p))).tasks]
    assert ids1 == ids2 and len(set(ids1)) == len(ids1)
    # one cell edited: only its runs get new ids
    p.write_text(CAMPAIGN.replace("onset_day: 2.0", "onset_day: 2.5"))
    plan = expand(load_campaign(str(p)))
    changed = {t.cell.fault for t, old in zip(plan.tasks, ids1) if t.id != old}
    assert changed == {"optical-bias-large"}
    a = {"x": 1.0, "y": [1, 2]}
    assert run_id(a, 1) != run_id(a, 2)
    assert run_id(a, 1) == run_id({"y": [1, 2], "x": 1.0}, 1)


def test_merge_dotted_and_nested_keys():
    data = {"sim": {"trajectory": {"span_days": 45.0, "rtol": 1e-12}}, "fsw": {"gating": [1]}}
    merge(data, {"sim.trajectory.span_days": 4.0, "fsw": {"gating": [2, 3]}})
    assert data == {"sim": {"trajectory": {"span_days": 4.0, "rtol": 1e-12}}, "fsw": {"gating": [2, 3]}}


BAD = [
    # (old, new, expected line, words in the message)
    ("seeds: {count: 2, base: 5}", "seeds: {count: 0, base: 5}", 2, ">= 1"),
    ("      - optical-bias-small", "      - optical-bias-smal", 10, "unknown fault preset"),
    ("        params: {chi2: {sigma_w: 0.1}}", "        params: {chi2: {sigma_v: 0.1}}", 18, "sigma_v"),
    ("        params: {chi2: {sigma_w: 0.1}}", "        params: {moe: {eta: 0.1}}", 18, "gating list"),
    ("onset_day: 1.5", "onset_day: 5.0", 10, "after the 3.0-day run"),
    ("  fsw.budget.mode: work-units", "  fsw.budget.mode: lazy", 4, "one of cpu, work-units"),
    ("  - scenarios: [short.yaml]", "  - scenarios: [no-such-scenario]", 7, "unknown name"),
    ("      - default\n", "      - default\n      - default\n", 7, "unique"),
]


@pytest.mark.parametrize("old,new,line,words", BAD)
def test_bad_campaign_is_one_line_with_file_and_line(tmp_path, short_scenario, capsys, old, new, line, words):
    assert old in CAMPAIGN
    p = _write(tmp_path, short_scenario, CAMPAIGN.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        expand(load_campaign(str(p)))
    msg = str(info.value)
    assert msg.startswith(f"{p}:{line}:"), msg
    assert words in msg, msg
    assert main(["campaign", str(p), "--dry-run", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(str(p))


def test_builtin_campaigns_expand():
    names = builtin_names()
    assert {"optical-bias", "lubey-ely-table3", "lubey-ely-table4", "detection-matrix"} <= set(names)
    plan = expand(load_campaign("optical-bias"))
    assert len(plan.tasks) == 4 * 3
    assert sorted({t.cell.fault for t in plan.tasks}) == ["none", "optical-bias-large", "optical-bias-medium",
                                                           "optical-bias-small"]
    t3 = expand(load_campaign("lubey-ely-table3"))
    assert len(t3.cells) == 7
    assert all([g["network"] for g in t.scenario["fsw"]["gating"]] == ["chi2", "magill"] for t in t3.tasks)
    from sim.faults.presets import FAULT_PRESETS
    from tools.campaign.spec import builtin_dir

    if builtin_dir().joinpath("detectors", "detector-chi2.yaml").is_file():
        # one run per case and seed carries all three detectors (tests/test_campaign_monitors.py)
        dm = expand(load_campaign("detection-matrix"))
        assert {t.cell.fault for t in dm.tasks} == set(FAULT_PRESETS)
        assert {t.detector_network for t in dm.tasks} == {"chi2"}
        assert all(sorted(t.monitors) == ["chi2-two-sided", "magill"] for t in dm.tasks)
        assert len(dm.tasks) == len(FAULT_PRESETS) * 100  # 100 seeds per cell
    else:  # the calibrations are not generated yet: a one-line error naming the missing file
        with pytest.raises(ConfigError, match="detectors/detector-chi2.yaml"):
            expand(load_campaign("detection-matrix"))
    t4 = expand(load_campaign("lubey-ely-table4"))
    banks = {t.cell.scenario: [f["name"] for f in t.scenario["fsw"]["bank"]["filters"]] for t in t4.tasks}
    assert all(len(b) == 6 for b in banks.values())
    dyn = [t for t in t4.tasks if t.fault_class == "dynamics"]
    assert dyn and all(t.scenario["sim"]["faults"][0]["onset_day"] == 0.0 for t in dyn)


def test_unknown_builtin_campaign_is_a_config_error(capsys):
    assert main(["campaign", "no-such-campaign", "--dry-run"]) == 2
    assert "optical-bias" in capsys.readouterr().err


def test_calibration_for_another_network_is_dropped(tmp_path, short_scenario):
    from fsw.fdir.config import DetectorConfig, config_to_yaml

    cal = DetectorConfig(network="chi2", filters=("radio", "optical", "fused"), nominal_mean=(1 / 3,) * 3,
                         nominal_cov=((1e-4, 0, 0), (0, 1e-4, 0), (0, 0, 1e-4)), threshold=3.0,
                         clear_threshold=2.0, onset_reference=1.0)
    (tmp_path / "det.yaml").write_text(config_to_yaml(cal))
    text = CAMPAIGN.replace("      - default\n", "      - {name: cal, calibration: det.yaml}\n")
    plan = expand(load_campaign(str(_write(tmp_path, short_scenario, text))))
    cal_runs = [t for t in plan.tasks if t.cell.variant == "cal"]
    assert cal_runs and all(t.detector_calibrated and t.scenario["fsw"]["detector"]["calibration"]["threshold"] == 3.0
                            for t in cal_runs)
    # a variant that moves the detector to magill cannot use a chi2 calibration
    text2 = CAMPAIGN.replace("      - default\n", "      - {name: cal, calibration: det.yaml}\n"
                             "      - {name: cal-magill, calibration: det.yaml, detector: magill}\n")
    plan2 = expand(load_campaign(str(_write(tmp_path, short_scenario, text2))))
    mag = [t for t in plan2.tasks if t.cell.variant == "cal-magill"]
    assert mag and not any(t.detector_calibrated for t in mag)
    assert all(t.scenario["fsw"]["detector"]["calibration"] is None for t in mag)

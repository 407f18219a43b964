"""Configuration errors reach the user as one line with file, line and key path, and exit code 2."""

import subprocess
import sys
from pathlib import Path

import pytest

from fsw.interface.yamlconfig import ConfigError, load_text
from tools.cli import main
from tools.scenario import ScenarioConfig, builtin_names, load_scenario, to_yaml

GOOD = """\
name: mine
description: a test scenario
seed: 3
sim:
  faults:
    - {type: optical-bias, onset_day: 10.0, sample_px: 2.0, line_px: 3.0}
fsw:
  gating:
    - network: chi2
      batch_size: 500
      sigma_w: 0.05
"""

# (replacement of one line of GOOD, expected line number, expected key path, expected words)
BAD = [
    ("seed: 3", "seed: three", 3, "seed", "an integer"),
    ("seed: 3", "seed: -1", 3, "seed", ">= 0"),
    ("seed: 3", "sed: 3", 3, "sed", "unknown key"),
    ("      sigma_w: 0.05", "      sigma_w: 0", 11, "fsw.gating[0].sigma_w", "> 0"),
    ("      batch_size: 500", "      batch_sise: 500", 10, "fsw.gating[0].batch_sise", "unknown key"),
    ("    - network: chi2", "    - network: chi3", 9, "fsw.gating[0].network", "one of"),
    ("    - {type: optical-bias, onset_day: 10.0, sample_px: 2.0, line_px: 3.0}",
     "    - {type: optical-bias, onset_day: ten, sample_px: 2.0, line_px: 3.0}", 6, "sim.faults[0].onset_day", "a number"),
    ("name: mine", "", None, "name", "missing key"),
    ("seed: 3", "seed: [3", 4, "", "valid YAML"),
    ("seed: 3", "seed: 3\nseed: 4", 4, "seed", "duplicate"),
]


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "scenario.yaml"
    p.write_text(text)
    return p


def test_good_file_validates(tmp_path, capsys):
    assert main(["validate", str(_write(tmp_path, GOOD))]) == 0
    assert "ok" in capsys.readouterr().out


@pytest.mark.parametrize("old,new,line,path,words", BAD)
def test_bad_file_gives_one_line_and_exit_2(tmp_path, capsys, old, new, line, path, words):
    assert old in GOOD
    f = _write(tmp_path, GOOD.replace(old, new, 1))
    assert main(["validate", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    where = f"{f}:{line}: " if line else f"{f}:"
    assert err.startswith(where), err
    if path:
        assert f" {path}: " in err
    assert words in err


def test_validate_as_a_real_process_exits_2_without_traceback(tmp_path):
    f = _write(tmp_path, GOOD.replace("seed: 3", "seed: x"))
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "validate", str(f)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert proc.stderr.strip().startswith(f"{f}:3: seed: expected an integer")


def test_missing_file(tmp_path, capsys):
    assert main(["validate", str(tmp_path / "nope.yaml")]) == 2
    assert "no such file" in capsys.readouterr().err


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_scenarios_show_as_complete_yaml_that_validates_unchanged(name, tmp_path, capsys):
    assert main(["scenarios", "--show", name]) == 0
    text = capsys.readouterr().out
    f = _write(tmp_path, text)
    assert main(["validate", str(f)]) == 0
    assert load_text(ScenarioConfig, text) == load_scenario(name)


def test_saved_config_leaves_defaults_out_and_round_trips():
    cfg = load_text(ScenarioConfig, GOOD)
    short = to_yaml(cfg, complete=False)
    assert "trajectory" not in short  # all defaults
    assert load_text(ScenarioConfig, short) == cfg


def test_scenarios_lists_builtins_and_presets(capsys):
    assert main(["scenarios"]) == 0
    out = capsys.readouterr().out
    for word in ("insight-approach", "optical-bias-medium", "radio-bias-large", "thruster-mismodel", "none"):
        assert word in out


def test_config_error_message_format():
    with pytest.raises(ConfigError) as info:
        load_text(ScenarioConfig, "name: x\nfsw:\n  reorder_window: -3\n", "f.yaml")
    assert str(info.value) == "f.yaml:3: fsw.reorder_window: expected a number >= 0, got -3"

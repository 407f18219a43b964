"""``--version``, plain-text ``--help`` and "did you mean" on mistyped names."""

from __future__ import annotations

import re
from importlib import metadata

import pytest

from fsw.interface.yamlconfig import ConfigError, load_text
from tools.cli import COMMANDS, main
from tools.commands.help_text import plain
from tools.scenario import ScenarioConfig, load_scenario, with_fault

MARKUP = re.compile(r"``|:[a-z]+:`")
NAMES = [m.rsplit(".", 1)[1].replace("_", "-") for m in COMMANDS]


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"navbank {metadata.version('navbank')}"


@pytest.mark.parametrize("argv", [[], *([n] for n in NAMES), ["ground", "log"]])
def test_help_has_no_markup(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "usage: navbank" in out
    assert not MARKUP.search(out), MARKUP.search(out)


def test_plain_removes_roles_and_literals():
    assert plain("producers can :func:`~fsw.transport.drain` into ``ground``") == "producers can `drain` into `ground`"
    assert plain(":class:`fsw.config.FswConfig`") == "`fsw.config.FswConfig`"


def test_mistyped_key_suggests_the_declared_one():
    with pytest.raises(ConfigError) as exc:
        load_text(ScenarioConfig, "name: x\nsim:\n  radiometric:\n    range_sigma: 2.0\n", "f.yaml")
    assert "f.yaml:4: sim.radiometric.range_sigma:" in str(exc.value)
    assert "unknown key 'range_sigma' (did you mean 'range_sigma_m'?)" in str(exc.value)


def test_mistyped_network_fault_and_scenario_suggest():
    with pytest.raises(ConfigError, match=r"'magil' \(did you mean 'magill'\?\)"):
        load_text(ScenarioConfig, "name: x\nfsw:\n  gating:\n    - {network: magil}\n")
    with pytest.raises(ConfigError, match=r"did you mean 'optical-bias'"):
        load_text(ScenarioConfig, "name: x\nsim:\n  faults:\n    - {type: optical-bais, onset_day: 1}\n")
    with pytest.raises(ConfigError, match=r"did you mean 'optical-bias-small'"):
        with_fault(load_scenario("insight-approach"), "optical-bias-smal")
    with pytest.raises(ConfigError, match=r"did you mean 'insight-approach'"):
        load_scenario("insight-aproach")


def test_a_name_far_from_every_key_gets_no_suggestion():
    with pytest.raises(ConfigError) as exc:
        load_text(ScenarioConfig, "name: x\nzzzz: 1\n")
    assert "did you mean" not in str(exc.value)


def test_mistyped_set_key_suggests_the_declared_one():
    from ground.replay.fsw_config import load_fsw_config
    from tools.scenario import resolve, to_yaml

    text = to_yaml(resolve(load_scenario("insight-approach"))[0])
    with pytest.raises(ConfigError) as exc:
        load_fsw_config(text, "run.mcap", overrides=["fsw.gating[0].sigma_ww=0.1"])
    assert str(exc.value).startswith("--set fsw.gating[0].sigma_ww=0.1: fsw.gating[0].sigma_ww:")
    assert "(did you mean 'sigma_w'?)" in str(exc.value)


@pytest.mark.parametrize("module_name", COMMANDS)
def test_each_command_is_found_by_its_name(module_name):
    """A command line imports only its command's module (``tools.cli.BY_NAME``): each module's
    NAME must be the name that map gives it."""
    import importlib

    from tools.cli import BY_NAME

    module = importlib.import_module(module_name)
    assert BY_NAME[module.NAME] == module_name


def test_a_command_line_imports_only_its_command():
    import subprocess
    import sys

    code = ("import sys; from tools.cli import main\n"
            "try:\n    main(['scenarios', '--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith('tools.commands.') and m.count('.') == 2))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True).stdout
    loaded = eval(out.strip().splitlines()[-1])
    assert "tools.commands.scenarios" in loaded
    assert "tools.commands.bench" not in loaded and "tools.commands.validation_report" not in loaded

"""The scenario and fault reference (docs/scenarios.md) and the commented ``scenarios --show``."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import yaml

from fsw.gating.registry import NETWORKS
from fsw.interface.annotated_yaml import annotated_yaml
from fsw.interface.typed import encode, spec
from fsw.interface.describe import describe
from fsw.interface.yamlconfig import load_text
from sim.faults.config import FAULT_TYPES, FaultConfig
from sim.faults.presets import FAULT_PRESETS
from tools.cli import main
from tools.scenario import ScenarioConfig, builtin_names, load_scenario
from tools.scenario_reference import REGENERATE, reference_markdown

DOC = Path(__file__).resolve().parent.parent / "docs" / "scenarios.md"


def test_committed_reference_is_current():
    assert DOC.read_text(encoding="utf-8") == reference_markdown(), (
        f"docs/scenarios.md is stale: a declaration changed; regenerate it with `{REGENERATE}`")


def _key_paths(data, mappings, prefix=""):
    """Dotted key paths of encoded data, list entries as ``[]``; the user's own names in a
    mapping (``sigma_scale: {range: 2}``) are values, not keys."""
    if isinstance(data, dict) and prefix not in mappings:
        for k, v in data.items():
            path = f"{prefix}.{k}" if prefix else k
            yield path
            yield from _key_paths(v, mappings, path)
    elif isinstance(data, list):
        for v in data:
            yield from _key_paths(v, mappings, prefix + "[]")


def test_reference_names_every_key_of_every_builtin_and_every_fault_network_preset():
    text = reference_markdown()
    gating_params = {k for cls in NETWORKS.values() for k in (f.name for f in dataclasses.fields(cls.params_type))}
    mappings = {r.path for r in describe(ScenarioConfig) if r.type.startswith("mapping")}
    for name in builtin_names():
        for path in _key_paths(encode(load_scenario(name)), mappings):
            if path.startswith("fsw.gating[]."):
                assert path.removeprefix("fsw.gating[].").split(".")[0] in gating_params | {"network"}
                continue
            assert f"| `{path}` |" in text, path
    for word in (*FAULT_TYPES, *FAULT_PRESETS, *NETWORKS, *builtin_names()):
        assert f"`{word}`" in text, word


def test_reference_rows_carry_unit_range_and_default():
    rows = {r.path: r for r in describe(ScenarioConfig)}
    entry = rows["sim.trajectory.entry_radius_km"]
    assert (entry.unit, entry.range, entry.default) == ("km", "> 3396.19", "3522.2")
    assert rows["sim.faults[].type"].default == "(required)"
    assert rows["sim.faults[].sigma_km_s2"].range == "≥ 0"
    assert "| `sim.trajectory.entry_radius_km` | number | km | > 3396.19 | `3522.2` |" in reference_markdown()


def test_reference_follows_a_changed_declaration():
    @dataclasses.dataclass(frozen=True)
    class Probe:
        speed: float = spec(2.0, doc="how fast", unit="m/s", ge=0.5)

    before = describe(Probe)
    Changed = dataclasses.make_dataclass(
        "Probe", [("speed", float, spec(3.0, doc="how fast", unit="km/s", ge=0.5))], frozen=True)
    after = describe(Changed)
    assert (before[0].unit, before[0].default) == ("m/s", "2.0")
    assert (after[0].unit, after[0].default) == ("km/s", "3.0")


@pytest.mark.parametrize("name", builtin_names())
def test_show_comments_every_key_and_leaves_out_nulls(name, capsys):
    assert main(["scenarios", "--show", name]) == 0
    text = capsys.readouterr().out
    assert load_text(ScenarioConfig, text) == load_scenario(name)
    body = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert all("  # " in ln for ln in body), [ln for ln in body if "  # " not in ln][:3]
    assert not [ln for ln in body if ln.split("  # ")[0].rstrip().endswith(": null")]
    assert "[km]" in text and "[s]" in text


def test_show_writes_only_the_fields_a_fault_has():
    cfg = load_scenario("insight-approach")
    text = annotated_yaml(cfg)
    faults = yaml.safe_load(text)["sim"]["faults"]
    assert faults == [{"type": "optical-bias", "onset_day": 20.0, "id": "", "sample_px": 2.0, "line_px": 3.0}]


def test_show_keeps_a_null_that_differs_from_its_default():
    @dataclasses.dataclass(frozen=True)
    class Probe:
        limit: float | None = spec(1.0, doc="a limit; null: none")

    assert annotated_yaml(Probe(limit=None)) == "limit: null  # a limit; null: none\n"
    assert annotated_yaml(FaultConfig(type="range-bias", onset_day=1.0, range_m=5.0)).count("\n") == 4

"""``navbank scenarios``: the built-in scenarios and fault presets, one scenario as commented
YAML, or the whole scenario and fault reference."""

from __future__ import annotations

from fsw.interface.annotated_yaml import annotated_yaml
from sim.faults.presets import FAULT_PRESETS
from tools.scenario import builtin_names, load_scenario

NAME = "scenarios"
HELP = "list built-in scenarios and fault presets, print one scenario as YAML, or the key reference"
DESCRIPTION = """List the built-in scenarios and fault presets. With --show NAME, print a built-in
scenario as complete YAML, every value with a comment giving its meaning, unit and range (keys
left null are left out): save it, edit it, and run it with `navbank run --scenario FILE`.
With --reference, print the scenario and fault reference (docs/scenarios.md) as Markdown."""


def add_arguments(p) -> None:
    p.add_argument("--show", metavar="NAME", help="print the built-in scenario NAME as complete, commented YAML")
    p.add_argument("--reference", action="store_true",
                   help="print the reference of every scenario key, fault type and built-in (Markdown)")


def _header(name: str, description: str) -> str:
    return (f"Scenario {name}: {description}\n"
            f"Every key with its meaning, [unit] and (range); a key left out keeps its default (docs/scenarios.md).\n"
            f"Save, edit and run: navbank run --scenario FILE")


def run(args) -> int:
    if args.reference:
        from tools.scenario_reference import reference_markdown

        print(reference_markdown(), end="")
        return 0
    if args.show:
        cfg = load_scenario(args.show)
        print(annotated_yaml(cfg, header=_header(cfg.name, cfg.description)), end="")
        return 0
    print("Built-in scenarios (navbank run --scenario NAME):")
    names = builtin_names()
    width = max(len(n) for n in names)
    for name in names:
        print(f"  {name:<{width}}  {load_scenario(name).description}")
    print("\nFault presets (navbank run --fault NAME; onset day 20 unless --onset-day is given):")
    width = max(len(n) for n in FAULT_PRESETS)
    for name, (desc, _) in FAULT_PRESETS.items():
        print(f"  {name:<{width}}  {desc}")
    print("\nEvery key, fault type and built-in: docs/scenarios.md (navbank scenarios --reference).")
    return 0

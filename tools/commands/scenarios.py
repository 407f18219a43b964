"""``navbank scenarios``: the built-in scenarios and fault presets."""

from __future__ import annotations

from sim.faults.presets import FAULT_PRESETS
from tools.scenario import builtin_names, load_scenario, to_yaml

NAME = "scenarios"
HELP = "list built-in scenarios and fault presets, or print one scenario as YAML"
DESCRIPTION = """List the built-in scenarios and fault presets. With --show NAME, print a built-in
scenario as complete YAML (every value, defaults included): save it, edit it, and run it with
`navbank run --scenario FILE`."""


def add_arguments(p) -> None:
    p.add_argument("--show", metavar="NAME", help="print the built-in scenario NAME as complete YAML")


def run(args) -> int:
    if args.show:
        print(to_yaml(load_scenario(args.show), complete=True), end="")
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
    return 0

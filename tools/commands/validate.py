"""``navbank validate FILE…``: check scenario files without running anything."""

from __future__ import annotations

import sys

from fsw.interface.yamlconfig import ConfigError, load_file
from tools.scenario import ScenarioConfig

NAME = "validate"
HELP = "check scenario YAML files (one line per problem, exit code 2 if any)"
DESCRIPTION = """Check scenario YAML files: syntax, unknown keys, types, ranges, required keys and
cross-field consistency. A bad file gives one line FILE:LINE: key.path: expected ..., got ...
and the exit code is 2. Nothing is started."""


def add_arguments(p) -> None:
    p.add_argument("files", nargs="+", metavar="FILE", help="scenario files to check")


def run(args) -> int:
    bad = 0
    for path in args.files:
        try:
            cfg = load_file(ScenarioConfig, path)
        except ConfigError as exc:
            print(exc, file=sys.stderr)
            bad += 1
            continue
        faults = ", ".join(f.type for f in cfg.sim.faults) or "none"
        nets = ", ".join(g.network for g in cfg.fsw.gating)
        print(f"{path}: ok  (scenario {cfg.name}; filters {', '.join(f.name for f in cfg.fsw.bank.filters)}; "
              f"gating {nets}; faults {faults})")
    return 2 if bad else 0

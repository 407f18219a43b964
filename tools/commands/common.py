"""Options and helpers several subcommands share (scenario selection, run ids)."""

from __future__ import annotations

import time
import uuid

from tools.commands.errors import UsageError
from tools.scenario import ScenarioConfig, load_scenario, with_fault


def add_scenario_arguments(p, default: str | None = "insight-approach") -> None:
    g = p.add_argument_group("scenario")
    g.add_argument("--scenario", default=default, metavar="S",
                   help=f"built-in scenario name or YAML file (default {default})" if default else "built-in scenario name or YAML file")
    g.add_argument("--fault", default=None, metavar="F", help="replace the scenario's faults by a preset (see `navbank scenarios`)")
    g.add_argument("--onset-day", type=float, default=None, metavar="D", help="onset of the --fault preset, days from the start (default 20)")
    g.add_argument("--seed", type=int, default=None, metavar="N", help="random seed (default: the scenario's)")


def scenario_from_args(args) -> ScenarioConfig:
    if args.onset_day is not None and args.fault is None:
        raise UsageError("--onset-day goes with --fault")
    if args.seed is not None and args.seed < 0:
        raise UsageError("--seed must be >= 0")
    return with_fault(load_scenario(args.scenario), args.fault, args.onset_day)


def new_run_id() -> str:
    return time.strftime("%Y%m%d-%H%M%S") + "-" + uuid.uuid4().hex[:6]

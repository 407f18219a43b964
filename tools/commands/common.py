"""Options and helpers several subcommands share (scenario selection, run ids, progress)."""

from __future__ import annotations

import sys
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


class ProgressBar:
    """One updating line on stderr: fraction, ETA."""

    def __init__(self, label: str, stream=sys.stderr):
        self.label = label
        self.stream = stream
        self.t0 = time.monotonic()
        self._tty = stream.isatty()
        self._last = -1.0

    def __call__(self, fraction: float, extra: str = "") -> None:
        now = time.monotonic()
        if not self._tty and fraction < 1.0 and now - self._last < 5.0:
            return
        self._last = now
        elapsed = now - self.t0
        eta = elapsed * (1 - fraction) / fraction if fraction > 0 else float("nan")
        width = 30
        fill = int(round(width * min(max(fraction, 0.0), 1.0)))
        line = (f"{self.label} [{'#' * fill}{'.' * (width - fill)}] {100 * fraction:5.1f} %  "
                f"elapsed {elapsed:5.0f} s  eta {eta:5.0f} s {extra}")
        end = "\r" if self._tty and fraction < 1.0 else "\n"
        print(line, end=end, file=self.stream, flush=True)

"""``navbank bench``: speed benchmarks, each against a reference measured in the same run."""

from __future__ import annotations

import sys

NAME = "bench"
HELP = "speed benchmarks (ratios against references measured in the same process)"
DESCRIPTION = """Speed benchmarks: one row per speed goal, each measured together with a reference
in the same run, printed as ours, reference, the ratio, the goal and whether it is met:
FSW core CPU per measurement and its FLOP rate against numpy's batched-matmul rate, the 45-day
in-process run's wall, budget overruns at the nominal budget, strict message decoding against
json.loads, the linear and EKF banks against FilterPy (the `bench` extra, pip install
"navbank[bench]"; without it those rows are skipped with a note), campaign runs per minute on 1
and 2 workers (local pool, dask LocalCluster, a dask scheduler and worker processes on loopback)
and, with --full, `navbank run`'s wall and its FSW process's CPU; last, whether the machine kept
its speed through the run (one fixed workload timed before each group and at the end: slowest /
fastest <= 1.1; above, the absolute figures of the run are uncertain by about that factor).
--json prints one JSON object per line (name, ours, reference, unit, ratio, goal, met, meaning,
details). --against REV runs one comparison instead: this tree's FSW core and the git revision
REV's on the same stream, in lock step on one processor (a drift of the machine falls on both),
their CPU per measurement, the ratio and whether their outputs are identical."""


def add_arguments(p) -> None:
    p.add_argument("--json", action="store_true", help="one JSON object per line")
    p.add_argument("--quick", action="store_true",
                   help="a 2-day arc and fewer repetitions: a rough figure in about a minute")
    p.add_argument("--full", action="store_true", help="also the rows that start `navbank run` (three processes)")
    p.add_argument("--against", metavar="REV",
                   help="instead: the FSW core of this tree against the git revision REV's (e.g. HEAD, main~3), "
                        "flown on the same stream in lock step, and whether their outputs are identical")


def run(args) -> int:
    from tools.bench import run_against, run_benchmarks

    if args.against is not None:
        from tools.bench.against import AgainstError

        try:
            run_against(args.against, json=args.json, quick=args.quick)
        except AgainstError as exc:
            print(f"navbank bench: {exc}", file=sys.stderr)
            return 2
        return 0
    run_benchmarks(json=args.json, quick=args.quick, full=args.full)
    return 0

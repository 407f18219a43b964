"""``navbank consistency``: NEES and NIS of one filter of the bank over nominal Monte Carlo seeds.

Flies the scenario without its fault for each seed (in-process, a spawn pool of ``--workers``) and
writes a JSON summary: the run-averaged NEES of position, velocity and both against the 95 % band
(with the fraction of epochs below and above it) and the NIS per measurement kind. A 45-day
``insight-approach`` run takes ~40 s of one core. ``navbank validation-report`` reads the file
from ``campaigns/filter-consistency.json``. Exit codes: 0 written, 2 bad arguments.
"""

from __future__ import annotations

import argparse

from tools.commands.outputs import check_output_file, emit_json

NAME = "consistency"
HELP = "NEES/NIS of a filter against truth over nominal seeds (JSON summary)"
DESCRIPTION = __doc__.split("\n", 2)[2] if __doc__ else HELP


def _positive(value: str) -> int:
    try:
        n = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value!r}")
    return n


def add_arguments(p) -> None:
    p.add_argument("--seeds", type=_positive, default=20, help="number of nominal runs (default 20)")
    p.add_argument("--first-seed", type=int, default=1001, help="seed of the first run (default 1001)")
    p.add_argument("--workers", type=_positive, default=2, help="processes flying runs in parallel (default 2)")
    p.add_argument("--scenario", default="insight-approach", help="scenario name or file (default insight-approach)")
    p.add_argument("--filter", default="fused", help="filter of the bank to test (default fused)")
    p.add_argument("--out", metavar="FILE", default=None, help="write the JSON summary here too")


def run(args) -> int:
    from tools.validation.filter_consistency import measure

    if args.out:
        check_output_file(args.out)
    emit_json(measure(args.seeds, args.first_seed, args.workers, args.scenario, args.filter), args.out)
    return 0

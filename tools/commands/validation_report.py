"""``navbank validation-report``: write docs/validation.md — the papers' findings reproduced by navbank.

Run the four built-in validation campaigns first (each resumes if interrupted), then this command:

    navbank campaign lubey-ely-table3 --out campaigns/lubey-ely-table3
    navbank campaign lubey-ely-table4 --out campaigns/lubey-ely-table4
    navbank campaign detection-matrix --out campaigns/detection-matrix
    navbank campaign overinflated --out campaigns/overinflated
    navbank validation-report --campaigns campaigns --out docs

It reads the campaigns' runs, draws their figures (``navbank report``), runs the Chaer et al. 1997
tracking experiments (~15 s) and its GA tuning (~40 s), the Chaer et al. 1998 Pathfinder cruise (in-process
runs, ~2 min, with EM on one recorded) and the optical-navigation camera experiment (27 optical-only runs,
~3 min), and writes OUT/validation.md with OUT/figures/. A campaign directory that is missing leaves its
section out (the command says which). Exit codes: 0 written, 2 bad arguments or no matplotlib.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ground.report.figure import PlottingUnavailable, figure_class
from tools.commands.outputs import check_output_dir

NAME = "validation-report"
HELP = "write the validation report (papers' findings vs navbank) from the validation campaigns"
DESCRIPTION = __doc__.split("\n", 2)[2] if __doc__ else HELP


def add_arguments(p) -> None:
    p.add_argument("--campaigns", metavar="DIR", default="campaigns",
                   help="directory holding the campaign directories (default ./campaigns)")
    p.add_argument("--out", metavar="DIR", default="docs", help="where validation.md and figures/ go (default ./docs)")
    p.add_argument("--no-cruise", action="store_true", help="leave out the Chaer et al. 1998 cruise run")
    p.add_argument("--no-optical", action="store_true", help="leave out the optical-navigation camera runs")


def run(args) -> int:
    from tools.validation.document import CAMPAIGNS, build

    camp = Path(args.campaigns)
    try:
        figure_class()  # without matplotlib nothing is made, not even the output directory
    except PlottingUnavailable as exc:
        print(f"navbank validation-report: {exc}", file=sys.stderr)
        return 2
    check_output_dir(args.out)  # before the cruise run and the figures: exit 2 for a directory we could not fill
    missing = [n for n in CAMPAIGNS if not (camp / n / "runs.jsonl").is_file()]
    for n in missing:
        print(f"navbank validation-report: no campaign {camp / n} (run: navbank campaign {n} --out {camp / n}); "
              "its section is left out", file=sys.stderr)
    try:
        path = build(camp, Path(args.out), cruise=not args.no_cruise, optical=not args.no_optical)
    except PlottingUnavailable as exc:
        print(f"navbank validation-report: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {path}")
    return 0

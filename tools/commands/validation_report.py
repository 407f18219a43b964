"""``navbank validation-report``: write docs/validation.md — the papers' findings reproduced by navbank.

Calibrate the shipped detectors and run the validation campaigns first (each resumes if
interrupted), then this command:

    navbank calibrate --plan insight-approach --out-dir calibrations/insight-approach \\
        --report campaigns/calibration-insight-approach.json   # and the other plans alike
    navbank campaign lubey-ely-table3 --out campaigns/lubey-ely-table3
    navbank campaign lubey-ely-table4 --out campaigns/lubey-ely-table4
    navbank campaign detection-matrix --out campaigns/detection-matrix
    navbank campaign overinflated --out campaigns/overinflated
    navbank consistency --seeds 20 --out campaigns/filter-consistency.json
    navbank false-alarms --seeds 100 --out campaigns/false-alarm-epochs.json
    navbank validation-report --campaigns campaigns --out docs

It reads the campaigns' runs and the calibration records, draws their figures (``navbank report``),
and flies its own experiments on ``--workers`` processes (:mod:`tools.validation.jobs`): the Chaer et
al. 1997 tracking experiments, GA tuning and RQP adaptation, the Hanlon & Maybeck 2000 dither cases,
Garhwal et al.'s injection case, the Chaer et al. 1998 Pathfinder cruise (with EM on one recorded)
and the optical-navigation camera experiment. It writes OUT/validation.md with OUT/figures/. A
campaign directory or record that is missing leaves its section out (the command says which for
the campaigns). Exit codes: 0 written, 2 bad arguments or no matplotlib.
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
    p.add_argument("--workers", type=int, default=2, metavar="N",
                   help="processes for the experiments the report flies itself (default 2)")


def run(args) -> int:
    from tools.validation.document import CAMPAIGNS, build

    camp = Path(args.campaigns)
    try:
        figure_class()  # without matplotlib nothing is made, not even the output directory
    except PlottingUnavailable as exc:
        print(f"navbank validation-report: {exc}", file=sys.stderr)
        return 2
    if args.workers < 1:
        print("navbank validation-report: --workers must be at least 1", file=sys.stderr)
        return 2
    check_output_dir(args.out)  # before the cruise run and the figures: exit 2 for a directory we could not fill
    missing = [n for n in CAMPAIGNS if not (camp / n / "runs.jsonl").is_file()]
    for n in missing:
        print(f"navbank validation-report: no campaign {camp / n} (run: navbank campaign {n} --out {camp / n}); "
              "its section is left out", file=sys.stderr)
    try:
        path = build(camp, Path(args.out), cruise=not args.no_cruise, optical=not args.no_optical,
                     workers=args.workers)
    except PlottingUnavailable as exc:
        print(f"navbank validation-report: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {path}")
    return 0

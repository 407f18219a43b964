"""``navbank report``: figures and a Markdown summary of a run or a campaign."""

from __future__ import annotations

import sys

from ground.mcap_io.reader import McapReadError
from ground.report.build import ReportInputError, classify, report
from ground.report.campaign_data import CampaignReadError
from ground.report.figure import PlottingUnavailable, figure_class
from tools.commands.outputs import check_output_dir

NAME = "report"
HELP = "plot a run (MCAP file or run directory) or a campaign directory, with a Markdown summary"
DESCRIPTION = """Write figures (PNG) and report.md for

  RUN.mcap        a recorded run (a summary.json beside it is used for the tables)
  RUN_DIR         a run directory: run.mcap (+ summary.json)
  CAMPAIGN_DIR    a campaign directory: runs.jsonl (+ summary.json)

Run figures: gating weights vs time, position error vs RTPC per filter, clock phase error,
anomaly statistic vs threshold, CPU budget and backlog, measurement timeline. Campaign figures:
mean weights per filter per fault case, confusion matrix, detection latency, detection
probability. The default output directory is report/ inside the run or campaign directory
(RUN-report/ beside a loose MCAP file). Needs matplotlib: pip install 'navbank[plots]'."""


def add_arguments(p) -> None:
    p.add_argument("path", metavar="RUN.mcap|RUN_DIR|CAMPAIGN_DIR", help="what to report")
    p.add_argument("--out", metavar="DIR", help="output directory (default: see above)")


def run(args) -> int:
    try:
        # what is to be reported and whether it can be drawn are known before the output
        # directory is made and proven writable (exit 2 otherwise), and that before any figure
        what = classify(args.path)
        figure_class()
        check_output_dir(args.out if args.out is not None else what.default_out)
        paths = report(args.path, args.out)
    except PlottingUnavailable as exc:
        print(f"navbank report: {exc}", file=sys.stderr)
        return 2
    except (ReportInputError, CampaignReadError, McapReadError) as exc:
        print(f"navbank report: {exc}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0

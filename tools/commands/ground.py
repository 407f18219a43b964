"""``navbank ground``: ground tools (``log``: record a run to MCAP)."""

from __future__ import annotations

import sys
import time

from ground import logger

NAME = "ground"
HELP = "ground tools: `navbank ground log` records a run to MCAP"
DESCRIPTION = """Ground tools. `navbank ground log --run-id ID --out FILE.mcap` subscribes to
navbank/<run-id>/** and writes one MCAP file (opens in Foxglove) until the simulator and the FSW
have ended their streams, or until SIGINT/SIGTERM (the file is always finished properly)."""


def add_arguments(p) -> None:
    sub = p.add_subparsers(dest="ground_command", metavar="TOOL", required=True)
    log = sub.add_parser("log", help="record a run to one MCAP file", description=logger.__doc__)
    logger.add_arguments(log)


def run(args) -> int:
    if args.ground_command == "log":
        rc = logger.main(args)
        print(f"ground log: process CPU {time.process_time():.1f} s", file=sys.stderr)
        return rc
    return 2

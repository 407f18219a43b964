"""``navbank recover``: rewrite a crashed recording (no footer) into a complete MCAP file."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ground.mcap_io.reader import McapReadError, is_complete, recover

NAME = "recover"
HELP = "rewrite an MCAP file left without its footer (a killed logger) into a complete file"
DESCRIPTION = """A logger killed without warning (SIGKILL, power loss) leaves run.mcap without its summary
and footer: plain MCAP readers (Foxglove, the mcap library's seeking reader) then refuse the
whole file. The logger closes a chunk at least twice a second, so all but the last fraction of a
second is still there: this command reads everything readable and writes it, with schemas,
channels, metadata and attachments, into a complete file (default RUN.recovered.mcap beside
it). It prints how many messages it kept per topic and why reading stopped. Exit 0 when a file
was written, 2 when the input is not an MCAP file or the output cannot be written."""


def add_arguments(p) -> None:
    p.add_argument("mcap", metavar="RUN.mcap", help="the crashed recording")
    p.add_argument("--out", metavar="FILE", default=None, help="where to write the complete file (default RUN.recovered.mcap)")
    p.add_argument("--force", action="store_true", help="also rewrite a file that is already complete")


def _fail(message: str) -> int:
    print(f"navbank recover: {message}", file=sys.stderr)
    return 2


def run(args) -> int:
    src = Path(args.mcap)
    dst = Path(args.out) if args.out else src.with_suffix(".recovered.mcap")
    try:
        if is_complete(src) and not args.force:
            print(f"{src}: already complete (summary and footer present); nothing to do (--force rewrites it)")
            return 0
        result = recover(src, dst)
    except McapReadError as exc:
        return _fail(str(exc))
    except (OSError, ValueError) as exc:
        return _fail(f"{dst}: {exc}" if not isinstance(exc, OSError) or exc.filename is None else str(exc))
    state = "complete" if result.complete else f"incomplete ({result.stopped or 'no footer'})"
    print(f"{src}: {state}; {result.messages} messages written to {dst}")
    for topic, n in sorted(result.counts.items()):
        print(f"  {topic:<40} {n:>9}")
    return 0 if os.path.exists(dst) else 2

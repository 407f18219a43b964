"""``navbank ground``: ground tools (``log``: record a run to MCAP)."""

from __future__ import annotations

import functools
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

from fsw.transport import TransportError
from ground import logger
from tools.commands.arg_types import run_id_arg
from tools.commands.errors import UsageError
from tools.commands.outputs import check_output_file, write_error_line, write_json
from tools.commands.transport_args import add_transport_arguments
from tools.rendezvous import joined

NAME = "ground"
HELP = "ground tools: `navbank ground log` records a run to MCAP"
DESCRIPTION = """Ground tools. `navbank ground log --run-id ID --out FILE.mcap` subscribes to
navbank/<run-id>/** and writes one MCAP file (opens in Foxglove) until the simulator and the FSW
have ended their streams, or until SIGINT/SIGTERM (the file is always finished properly)."""


LOG_DESCRIPTION = """Record every message of run ID (Zenoh keys navbank/<run-id>/**) into one MCAP file that
Foxglove opens: ICD topics on channels with their JSON Schema, anything else on schema-less
channels, payloads that fail strict decoding on /_invalid/<topic> (counted, never dropped).

It stops by itself once every producer (--producers, default sim and fsw) has published its
end-of-run status and everything announced has been recorded; on SIGINT/SIGTERM or --duration
it stops too, and the file is always finished. A killed logger (SIGKILL) leaves a file that
`navbank recover` completes.

Without transport options it listens on a free loopback port, prints it, and announces it to
the run's other processes on this host (navbank sim, fsw and replay with the same --run-id and
no transport options connect to it by themselves). --listen/--connect put processes on
different hosts or behind a router."""


def add_arguments(p) -> None:
    sub = p.add_subparsers(dest="ground_command", metavar="TOOL", required=True)
    log = sub.add_parser("log", help="record a run to one MCAP file", description=LOG_DESCRIPTION)
    _add_log_arguments(log)
    log.set_defaults(_name="ground log")  # how its errors are signed


def _add_log_arguments(parser) -> None:
    """Options of ``navbank ground log``."""
    parser.add_argument("--run-id", type=run_id_arg, required=True, metavar="ID", help="run to record (Zenoh keys navbank/<run-id>/**)")
    parser.add_argument("--out", required=True, metavar="FILE", help="MCAP file to write")
    parser.add_argument("--producers", default="sim,fsw", metavar="LIST",
                        help="comma-separated processes whose end-of-run ends the recording (default sim,fsw)")
    parser.add_argument("--no-wait-end", action="store_true", help="ignore end-of-run; record until SIGINT/SIGTERM or --duration")
    parser.add_argument("--duration", type=float, default=None, metavar="S", help="stop after S seconds")
    parser.add_argument("--attach", action="append", default=[], metavar="FILE", help="attach a file, e.g. the scenario YAML (repeatable)")
    parser.add_argument("--no-validate", action="store_true", help="record without strict ICD decoding (faster)")
    parser.add_argument("--flush-interval", type=float, default=0.5, metavar="S",
                        help="close the open chunk at least every S seconds (data lost on SIGKILL, default 0.5)")
    parser.add_argument("--after", action="append", default=[], metavar="SEGMENT",
                        help="an earlier segment of the same run (a logger that died): what it holds is not recorded again "
                             "(repeatable, in order)")
    parser.add_argument("--log-time", choices=("mission", "receive"), default="mission",
                        help="MCAP log_time of each message: its mission time, so Foxglove plays the mission back in "
                        "order and evenly (default), or the time the logger received it")
    parser.add_argument("--no-foxglove", action="store_true",
                        help="record only the ICD channels, without the Foxglove scene, log and plot channels")
    parser.add_argument("--live", action="store_true",
                        help="also serve every channel over Foxglove's WebSocket protocol while recording")
    parser.add_argument("--live-host", default="127.0.0.1", metavar="HOST", help="address of the live view (default 127.0.0.1)")
    parser.add_argument("--live-port", type=int, default=8765, metavar="PORT",
                        help="port of the live view (default 8765, Foxglove's; 0: any free port)")
    parser.add_argument("--summary", default=None, metavar="FILE",
                        help="also write the run's summary (summary.json's numbers, from the messages as they are "
                        "recorded) to FILE once the run has ended; needs --summary-context")
    parser.add_argument("--summary-context", default=None, metavar="JSON",
                        help='what the recording does not say about the run: {"scenario": NAME, "seed": N, '
                        '"fault": PRESET or null, "t0": scenario start [s TDB past J2000]}')
    add_transport_arguments(parser)


#: --summary-context's keys and the JSON types each takes
_CONTEXT_KEYS = {"scenario": (str,), "seed": (int,), "fault": (str, type(None)), "t0": (int, float)}


def summary_context(text: str) -> dict[str, Any]:
    """The run facts of ``--summary-context`` (UsageError, exit 2, for anything else)."""
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise UsageError(f"--summary-context: not JSON ({exc})") from None
    if not isinstance(value, dict) or set(value) != set(_CONTEXT_KEYS):
        raise UsageError(f"--summary-context: expected an object with exactly the keys {', '.join(_CONTEXT_KEYS)}")
    for key, types in _CONTEXT_KEYS.items():
        v = value[key]
        if isinstance(v, bool) or not isinstance(v, types):
            raise UsageError(f"--summary-context: {key} must be {' or '.join(t.__name__ for t in types)}, got {v!r}")
    if not math.isfinite(value["t0"]):
        raise UsageError(f"--summary-context: t0 must be finite, got {value['t0']!r}")
    value["t0"] = float(value["t0"])
    return value


def _log(args) -> int:
    """Run ``navbank ground log``; 0 on success, 1 if the network or the file failed."""
    check_output_file(args.out)  # before subscribing: exit 2 for a file we could not write
    feed = context = None
    if (args.summary is None) != (args.summary_context is None):
        raise UsageError("--summary and --summary-context go together")
    if args.summary is not None:
        from ground.report.summary_feed import SummaryFeed  # imported before the run: not on its wall time

        check_output_file(args.summary, "--summary")
        context = summary_context(args.summary_context)
        feed = SummaryFeed()
    try:
        producers = tuple(p.strip() for p in args.producers.split(",") if p.strip())
        with joined(args, args.run_id, "ground", name="ground log") as cfg:
            logger.run_logger(
                args.run_id,
                args.out,
                cfg,
                producers=producers,
                until_end_of_run=not args.no_wait_end and bool(producers),
                max_duration_s=args.duration,
                validate=not args.no_validate,
                attachments=args.attach,
                flush_interval_s=args.flush_interval,
                after=args.after,
                mission_time=args.log_time == "mission",
                foxglove_channels=not args.no_foxglove,
                live=(args.live_host, args.live_port) if args.live else None,
                feed=feed,
                # the summary is written while the session lets its last replies leave (it waits 0.2 s for them anyway)
                on_closed=None if feed is None or context is None else
                functools.partial(_write_fed_summary, feed, context, Path(args.summary), segment=bool(args.after)),
            )
    except OSError as exc:
        # the only file the logger writes is --out; an error from write() or flush() carries no
        # file name, so name it here (an attachment that cannot be read names itself)
        print(f"navbank ground log: {write_error_line(exc, args.out)}", file=sys.stderr)
        return 1
    except (TransportError, ValueError) as exc:
        print(f"navbank ground log: {exc}", file=sys.stderr)
        return 1
    return 0


def _write_fed_summary(feed: Any, context: dict[str, Any], path: Path, result: logger.LogResult, segment: bool) -> None:
    """The summary of what this logger recorded, for a run it recorded whole: ended by the
    producers' end-of-run, on one segment. Otherwise (or if it cannot be computed or written)
    nothing is written and the reason printed: the run's summary then comes from the recording."""
    why = ("the recording is a later segment of its run" if segment
           else f"the recording ended by {result.ended_by}, not by the run's end" if result.ended_by != "end-of-run"
           else feed.spoiled)
    try:
        path.unlink(missing_ok=True)  # never leave an earlier run's summary standing for this one
        if why is None:
            # with the logger's counts the run's summary reports (the recording's closing record holds them too)
            write_json({"summary": feed.summarize(**context).to_json(),
                        "logger": {"duplicates": result.duplicates, "gaps": result.gaps}}, path)
            return
    except Exception as exc:  # whatever it is, the read-back will meet it too and say it
        why = f"{type(exc).__name__}: {exc}"
    print(f"navbank ground log: no summary written to {path} ({why})", file=sys.stderr)


def run(args) -> int:
    if args.ground_command == "log":
        rc = _log(args)
        if rc == 0:  # after an error its line stays the last one (the launcher shows the last line)
            print(f"ground log: process CPU {time.process_time():.1f} s", file=sys.stderr)
        return rc
    return 2

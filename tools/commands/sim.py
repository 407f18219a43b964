"""``navbank sim``: the truth/sensor simulator — to a file, or published over Zenoh."""

from __future__ import annotations

import sys
import time

import fsw.transport as tp
from sim.stream import generate
from tools.commands.errors import UsageError
from tools.commands.arg_types import run_id_arg
from tools.commands.common import add_scenario_arguments, scenario_from_args
from tools.commands.outputs import check_output_file, write_error_line
from tools.commands.transport_args import add_transport_arguments, transport_config_from_args
from tools.rendezvous import joined
from tools.progress import advance_to, progress_bar
from tools.scenario import resolve

NAME = "sim"
HELP = "run the truth/sensor simulator: write the stream to a file or publish it over Zenoh"
DESCRIPTION = """Generate a scenario's measurements, truth and fault events (time-ordered, sequence-numbered
ICD messages). With --out FILE (.jsonl: one ICD message per line with its topic; .mcap: opens in
Foxglove) the stream is written to files; with --run-id it is published over Zenoh under
navbank/<run-id>/sim/... for `navbank fsw` and `navbank ground log` (as `navbank run` does)."""


def add_arguments(p) -> None:
    add_scenario_arguments(p)
    p.add_argument("--out", action="append", default=[], metavar="FILE", help="write the stream to FILE (.jsonl or .mcap; repeatable)")
    p.add_argument("--run-id", type=run_id_arg, default=None, metavar="ID", help="publish over Zenoh as run ID")
    p.add_argument("--rate", type=float, default=None, metavar="X", help="publish at X times real time (default: as fast as possible)")
    p.add_argument("--consumers", default="fsw,ground", metavar="LIST",
                   help="roles that must be up before publishing and confirm the end (default fsw,ground)")
    p.add_argument("--window", type=int, default=2000, metavar="N", help="credit window: measurements ahead of the FSW (default 2000)")
    p.add_argument("--hold-for-logger", type=float, default=None, metavar="S",
                   help="once the logger was up, hold publishing while it is away (restarting), at most S seconds each time")
    add_transport_arguments(p)


def _write(run, path: str) -> int:
    if path.endswith(".jsonl"):
        from sim.io import write_run

        return write_run(run, path)
    if path.endswith(".mcap"):
        from fsw.interface.messages import Stamp
        from ground.mcap_io.recorder import McapRecorder

        n = 0
        with McapRecorder(path) as rec:
            for topic, msg in run.iter_messages():
                rec.write_message(topic, msg, log_time_ns=msg.timestamp.to_ns() if isinstance(msg.timestamp, Stamp) else None)
                n += 1
        return n
    raise UsageError(f"--out {path}: expected a .jsonl or .mcap file name")


def run(args) -> int:
    if not args.out and args.run_id is None:
        raise UsageError("give --out FILE and/or --run-id ID")
    if args.rate is not None and args.rate <= 0:
        raise UsageError("--rate must be > 0")
    for path in args.out:
        if not path.endswith((".jsonl", ".mcap")):
            raise UsageError(f"--out {path}: expected a .jsonl or .mcap file name")
        check_output_file(path)  # before the simulation: exit 2 for a file we could not write
    if args.run_id is not None:
        transport_config_from_args(args, "sim")  # bad transport options or credentials: exit 2 before generating
    cfg, seed = resolve(scenario_from_args(args), args.seed)
    t0 = time.perf_counter()
    run_ = generate(cfg.sim, seed=seed)
    per_kind = ", ".join(f"{n} {k}" for k, n in sorted(run_.counts().items()))
    print(f"sim: {cfg.name} seed {seed}: {len(run_.measurements)} measurements ({per_kind}), "
          f"{len(run_.truth)} truth, {len(run_.fault_events)} fault events in {time.perf_counter() - t0:.1f} s",
          file=sys.stderr)
    for path in args.out:
        try:
            n = _write(run_, path)
        except OSError as exc:  # e.g. the disk filled up while writing; a write error has no file name
            print(f"navbank sim: {write_error_line(exc, path)}", file=sys.stderr)
            return 1
        print(f"sim: wrote {n} messages to {path}", file=sys.stderr)
    if args.run_id is not None:
        from sim.app import publish_run

        consumers = tuple(c.strip() for c in args.consumers.split(",") if c.strip())
        span = cfg.sim.span_days
        bar = progress_bar(span, desc="sim", unit="day")
        try:
            with joined(args, args.run_id, "sim") as transport:
                counts = publish_run(run_, args.run_id, transport, consumers=consumers,
                                     credit_role="fsw" if "fsw" in consumers else None, window=args.window,
                                     rate=args.rate, progress=lambda fraction: advance_to(bar, fraction * span),
                                     hold_for_logger_s=args.hold_for_logger)
        except tp.TransportError as exc:
            bar.close()
            print(f"navbank sim: {exc}", file=sys.stderr)
            return 1
        bar.close()
        if counts.get("consumer_restarts"):
            print(f"sim: the FSW restarted {counts['consumer_restarts']} time(s); {counts['resent']} measurements "
                  "sent again after its checkpoints", file=sys.stderr)
        print(f"sim: published {counts.get('measurements', 0)} measurements as run {args.run_id}; "
              f"credit window: {counts.get('credit_waits', 0)} waits, {counts.get('credit_queries', 0)} progress "
              f"queries; process CPU {time.process_time():.1f} s", file=sys.stderr)
    return 0

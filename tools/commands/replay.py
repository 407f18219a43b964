"""``navbank replay``: republish a recorded run over Zenoh, or re-run its FSW and diff the telemetry."""

from __future__ import annotations

import json
import math
import sys

import fsw.transport as tp
from fsw.interface.yamlconfig import ConfigError
from tools.commands.arg_types import run_id_arg
from tools.commands.common import new_run_id
from tools.commands.outputs import check_output_dir, check_output_file
from tools.commands.transport_args import add_transport_arguments
from tools.rendezvous import joined

NAME = "replay"
HELP = "republish a recorded run over Zenoh, or re-run its FSW on the recorded measurements (--rerun)"
DESCRIPTION = """Two ways to replay a run recorded by `navbank run` / `navbank ground log`:

  navbank replay RUN.mcap [--rate X] [--run-id ID] [--consumers ground]
      republishes every recorded message over Zenoh under a new run id (default: a fresh one),
      in the order the ground received them and paced by the recorded receive times divided
      by X (--rate 0 or --fast: as fast as possible). The payloads are the recorded bytes.
      The recorded sim/fsw end-of-run statuses are replayed too, then a RunStatus
      (source "replay", end-of-run, per-topic counts) on ground/status. A second logger
      started with `navbank ground log --run-id ID --out B.mcap --producers replay` ends when it
      has everything the replay announced (with --consumers ground the replay waits for it
      before starting and drains into it at the end: nothing is lost); with --producers sim,fsw
      it ends 2 s after the replayed sim and fsw end-of-run statuses and their counts arrived.
      Without --consumers nothing is waited for: start displays/loggers (and --connect to
      them) first, or the first messages go out before anyone subscribes.

  navbank replay RUN.mcap --rerun [--set fsw.PATH=VALUE ...] [--config FILE] [--tolerance T] [--rtol R] [--out DIR]
      feeds the recorded measurements into a fresh FSW in this process, built from the
      configuration attached to the run (its fsw: section), and compares its telemetry with
      the recorded /fsw/... messages: counts per topic and the largest absolute and relative
      (|a - b| / max(|a|, |b|)) difference per field. Exit 0 when every number is within the
      tolerance or within the relative tolerance (defaults 0: bit for bit) and every flag,
      class and name is equal, 1 otherwise.
      Runs in work-unit budget mode are deterministic; runs in CPU mode are re-run in CPU mode
      and may legitimately differ in budget reports (compared by count only) and in
      combined/best estimates. --set/--config change the FSW to see a change show up, e.g.
      --set fsw.gating[0].sigma_w=0.1. A change to the parameters of the network a calibrated
      detector watches is flagged: the calibration no longer applies. --out DIR also writes
      the re-run as a run (DIR/run.mcap, DIR/config.yaml) that `navbank report DIR` draws."""


def _fail(message: str, code: int = 2) -> int:
    print(f"navbank replay: {message}", file=sys.stderr)
    return code


def add_arguments(p) -> None:
    p.add_argument("mcap", metavar="RUN.mcap", help="recorded run (e.g. runs/<id>/run.mcap)")
    g = p.add_argument_group("republish over Zenoh (default)")
    g.add_argument("--run-id", type=run_id_arg, default=None, metavar="ID", help="run id to publish under (default: a new one)")
    g.add_argument("--rate", type=float, default=1.0, metavar="X",
                   help="speed-up of the recorded timing (default 1: real time; 0: as fast as possible)")
    g.add_argument("--fast", action="store_true", help="as fast as possible (same as --rate 0)")
    g.add_argument("--consumers", default="", metavar="LIST",
                   help="roles to wait for before the first message and drain into at the end, e.g. ground")
    g.add_argument("--consumer-timeout", type=float, default=30.0, metavar="S",
                   help="seconds to wait for the consumers to appear (default 30)")
    g.add_argument("--quiet", action="store_true", help="no progress lines")
    add_transport_arguments(p)
    r = p.add_argument_group("re-run the FSW (--rerun)")
    r.add_argument("--rerun", action="store_true", help="re-run the FSW on the recorded measurements and diff its telemetry")
    r.add_argument("--set", dest="overrides", action="append", default=[], metavar="fsw.PATH=VALUE",
                   help="change one FSW parameter, e.g. fsw.gating[0].sigma_w=0.1 (repeatable)")
    r.add_argument("--config", default=None, metavar="FILE",
                   help="replace the recorded FSW config by this scenario's fsw: section (or a bare fsw mapping)")
    r.add_argument("--tolerance", type=float, default=0.0, metavar="T", help="largest absolute difference accepted (default 0)")
    r.add_argument("--rtol", type=float, default=0.0, metavar="R",
                   help="largest relative difference |a - b| / max(|a|, |b|) accepted (default 0)")
    r.add_argument("--largest", type=int, default=10, metavar="N", help="list the N largest differences (default 10)")
    r.add_argument("--json", default=None, metavar="FILE", help="also write the comparison as JSON")
    r.add_argument("--out", default=None, metavar="DIR",
                   help="also write the re-run as a run: DIR/run.mcap (recorded measurements and truth, the re-run's "
                   "FSW telemetry) and DIR/config.yaml, for `navbank report DIR`")


def _rerun(args) -> int:
    from ground.mcap_io.reader import McapReadError
    from ground.replay.recording import RecordingError
    from ground.replay.regression import format_result, rerun_and_compare

    if not (args.tolerance >= 0 and math.isfinite(args.tolerance)):
        return _fail("--tolerance must be >= 0")
    if not (args.rtol >= 0 and math.isfinite(args.rtol)):
        return _fail("--rtol must be a finite number >= 0")
    if args.json:
        check_output_file(args.json, "--json")  # before the re-run: exit 2 for a file we could not write
    if args.out:
        check_output_dir(args.out)
    try:
        res = rerun_and_compare(args.mcap, overrides=args.overrides, replacement=args.config, tolerance=args.tolerance,
                                rtol=args.rtol)
    except ConfigError:
        raise
    except (RecordingError, McapReadError) as exc:
        return _fail(str(exc))
    except ValueError as exc:  # a malformed --set
        return _fail(str(exc))
    print(format_result(res, largest=max(args.largest, 0)))
    if args.out:
        from ground.replay.rerun_record import rerun_config_text, write_rerun_run

        text = rerun_config_text(res.recorded_config, res.config, res.recorded_config_name)
        path = write_rerun_run(args.mcap, res.rerun, text, args.out, run_id=res.run_id or "rerun", changes=res.changes)
        print(f"re-run written to {path} (navbank report {args.out})")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"run_id": res.run_id, "changes": res.changes, "notes": res.notes, **res.comparison.to_dict()}, f, indent=2)
    return 0 if res.identical else 1


def _republish(args) -> int:
    from ground.mcap_io.reader import McapReadError
    from ground.replay.recording import RecordingError
    from ground.replay.republish import republish

    if args.overrides or args.config:
        return _fail("--set and --config go with --rerun")
    rate = 0.0 if args.fast else args.rate
    if not (rate >= 0 and math.isfinite(rate)):
        return _fail("--rate must be a finite number >= 0 (0: as fast as possible)")
    consumers = tuple(c.strip() for c in args.consumers.split(",") if c.strip())
    for c in consumers:
        if c not in tp.ROLES:
            return _fail(f"--consumers: {c!r} is not one of {', '.join(tp.ROLES)}")
    run_id = args.run_id or new_run_id()
    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    print(f"navbank replay: {args.mcap} -> run {run_id} at rate {rate:g}"
          + (f", consumers {', '.join(consumers)}" if consumers else ""), file=sys.stderr)
    try:
        with joined(args, run_id, "replay") as cfg:
            res = republish(args.mcap, run_id, cfg, rate=rate, consumers=consumers,
                            consumer_timeout_s=args.consumer_timeout, progress=progress)
    except (RecordingError, McapReadError) as exc:
        return _fail(str(exc))
    except tp.TransportError as exc:
        return _fail(str(exc), 1)
    print(res.report())
    return 0 if all(res.drained.values()) and not res.stopped else 1


def run(args) -> int:
    try:
        return _rerun(args) if args.rerun else _republish(args)
    except OSError as exc:
        return _fail(str(exc))


"""``navbank fsw``: the flight-software process."""

from __future__ import annotations

import dataclasses
import sys
import time

import fsw.transport as tp
from fsw.app import run_fsw, stderr_progress
from fsw.core.checkpoint import CheckpointError
from tools.commands.arg_types import run_id_arg
from tools.commands.errors import UsageError
from tools.commands.outputs import check_output_file
from tools.commands.common import add_scenario_arguments, scenario_from_args
from tools.commands.transport_args import add_transport_arguments
from tools.rendezvous import joined
from tools.scenario import resolve

NAME = "fsw"
HELP = "run the flight software (filter bank, gating, anomaly detector) on a Zenoh run"
DESCRIPTION = """Run the flight software for one run: subscribe to navbank/<run-id>/sim/measurements (never
truth), run the filter bank, gating networks and anomaly detector under the frame executive,
publish weights, anomaly reports, estimates and budget reports, and answer telecommands on
navbank/<run-id>/fsw/cmd. Only the scenario's fsw section is used (plus the seed, for the
a-priori state when the file does not give fsw.initial_state)."""


def add_arguments(p) -> None:
    add_scenario_arguments(p)
    p.add_argument("--run-id", type=run_id_arg, required=True, metavar="ID", help="run to join")
    p.add_argument("--consumers", default="ground", metavar="LIST", help="roles that must confirm the end of the telemetry (default ground)")
    p.add_argument("--idle-timeout", type=float, default=None, metavar="S", help="give up after S seconds without data")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    g = p.add_argument_group("checkpoints (a supervised restart goes on from the last one)")
    g.add_argument("--checkpoint", default=None, metavar="FILE", help="save the FSW's state to FILE at the checkpoint cadence")
    g.add_argument("--checkpoint-every", type=int, default=None, metavar="N",
                   help="checkpoint every N measurements (default: the scenario's fsw.checkpoint.every_measurements)")
    g.add_argument("--hold-for-logger", type=float, default=None, metavar="S",
                   help="once the logger was up, hold telemetry while it is away (restarting), at most S seconds each time")
    g.add_argument("--resume", default=None, metavar="FILE", help="go on from the checkpoint FILE (the producer resends what came after it)")
    add_transport_arguments(p)


def run(args) -> int:
    cfg, _ = resolve(scenario_from_args(args), args.seed)
    consumers = tuple(c.strip() for c in args.consumers.split(",") if c.strip())
    fsw_cfg = cfg.fsw
    if args.checkpoint_every is not None:
        if args.checkpoint_every < 0:
            raise UsageError("--checkpoint-every must be >= 0")
        fsw_cfg = dataclasses.replace(fsw_cfg, checkpoint=dataclasses.replace(
            fsw_cfg.checkpoint, every_measurements=args.checkpoint_every))
    if args.checkpoint is not None:
        check_output_file(args.checkpoint, "--checkpoint")
    try:
        with joined(args, args.run_id, "fsw") as transport:
            counts = run_fsw(fsw_cfg, args.run_id, transport, consumers=consumers,
                             progress=None if args.quiet else stderr_progress, idle_timeout_s=args.idle_timeout,
                             checkpoint_path=args.checkpoint, resume=args.resume, hold_for_logger_s=args.hold_for_logger)
    except CheckpointError as exc:
        print(f"navbank fsw: {exc}", file=sys.stderr)
        return 2
    except tp.TransportError as exc:
        print(f"navbank fsw: {exc}", file=sys.stderr)
        return 1
    print(f"fsw: processed {counts.get('processed', 0)}, rejected {counts.get('rejected', 0)}, "
          f"lost {counts.get('lost', 0)}; process CPU {time.process_time():.1f} s", file=sys.stderr)
    return 0

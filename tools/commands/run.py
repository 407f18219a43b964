"""``navbank run``: the main job — simulator, flight software and ground logger together."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from typing import TYPE_CHECKING, Any, Callable
import sys
import time
from pathlib import Path

from tools.commands.errors import UsageError
from tools.commands.arg_types import run_id_arg
from tools.commands.common import add_scenario_arguments, new_run_id, scenario_from_args
from tools.commands.outputs import check_output_dir, write_error_line
from tools.launcher import DEFAULT_MAX_RESTARTS, LOGGER_SUMMARY, Restart, RunFailed, launch, write_summary
from fsw.transport.session import free_tcp_ports
from tools.progress import advance_to, fsw_progress, progress_bar
from tools.scenario import ScenarioConfig, resolve

if TYPE_CHECKING:
    from ground.report.summary_types import RunEnding, RunSummary

NAME = "run"
HELP = "run simulator + FSW + ground logger as separate processes over Zenoh and report"
DESCRIPTION = """Start the ground logger, the flight software and the truth/sensor simulator as three
processes talking over Zenoh on loopback, supervise them, and report in plain words: the filters,
mean gating weights, whether and when an anomaly was declared, its latency from the true onset,
the diagnosed class against the injected fault, position errors against truth, and the budget.

Writes DIR/run.mcap (open it in Foxglove), DIR/summary.json, DIR/config.yaml (the exact
configuration, re-runnable with --scenario DIR/config.yaml) and a log per process.

A process that dies is restarted (at most --max-restarts times each): the FSW from its last
checkpoint (DIR/fsw.ckpt; the simulator sends again what came after it), the logger on a new
segment (DIR/run.seg<n>.mcap, merged into DIR/run.mcap at the end). summary.json lists the
restarts and what, if anything, was never recorded.

Default: the insight-approach scenario with a medium optical bias from day 20 of 45."""


def add_arguments(p) -> None:
    add_scenario_arguments(p)
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default runs/<run-id>)")
    p.add_argument("--run-id", type=run_id_arg, default=None, metavar="ID", help="Zenoh run id (default: time + random)")
    g = p.add_argument_group("budget")
    g.add_argument("--budget-mode", choices=("cpu", "work-units"), default=None, help="budget accounting (default: the scenario's)")
    g.add_argument("--budget", type=float, default=None, metavar="FRACTION",
                   help="budget per frame as a fraction of the scenario's (e.g. 0.25 for a quarter)")
    g.add_argument("--cpu-scale", type=float, default=None, metavar="X", help="charge X times the measured CPU (a slower flight processor)")
    p.add_argument("--timeout", type=float, default=3600.0, metavar="S", help="stop everything after S seconds (default 3600)")
    p.add_argument("--max-restarts", type=int, default=DEFAULT_MAX_RESTARTS, metavar="N",
                   help=f"restart a dying FSW (from its last checkpoint) or logger (on a new segment) at most N times "
                        f"each (default {DEFAULT_MAX_RESTARTS}; 0: never)")
    p.add_argument("--checkpoint-every", type=int, default=None, metavar="N",
                   help="FSW checkpoint every N measurements (default: the scenario's fsw.checkpoint.every_measurements)")
    p.add_argument("--rate", type=float, default=None, metavar="X",
                   help="the simulator publishes at X times real time, e.g. 86400 for a simulated day per second "
                        "while watching with --live (default: as fast as the FSW takes it)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--plain-tcp", action="store_true",
                   help="plain TCP links without authentication (default: mutual TLS, access control and signed "
                        "telecommands and end-of-run statuses, with credentials made for this run and removed when it ends)")
    g = p.add_argument_group("live view")
    g.add_argument("--live", action="store_true",
                   help="serve the run's channels (weights, residuals, 3-D scene, ...) over Foxglove's WebSocket protocol "
                   "while it flies; open the printed ws:// address in Foxglove (Open connection)")
    g.add_argument("--live-host", default="127.0.0.1", metavar="HOST", help="address to serve on (default 127.0.0.1)")
    g.add_argument("--live-port", type=int, default=8765, metavar="PORT",
                   help="port to serve on (default 8765, what Foxglove proposes; 0: any free port)")


def with_budget(cfg: ScenarioConfig, mode: str | None, fraction: float | None, cpu_scale: float | None) -> ScenarioConfig:
    b = cfg.fsw.budget
    changes: dict[str, Any] = {}
    if mode is not None:
        changes["mode"] = mode
    if fraction is not None:
        if not fraction > 0:
            raise UsageError("--budget must be > 0")
        changes["cpu_budget_s"] = b.cpu_budget_s * fraction
        changes["work_unit_budget"] = b.work_unit_budget * fraction
    if cpu_scale is not None:
        if not cpu_scale > 0:
            raise UsageError("--cpu-scale must be > 0")
        changes["cpu_scale"] = cpu_scale
    if not changes:
        return cfg
    return dataclasses.replace(cfg, fsw=dataclasses.replace(cfg.fsw, budget=dataclasses.replace(b, **changes)))


def _merge_segments(out: Path) -> list[Any]:
    """A restarted logger left the recording in segments: merge them into ``run.mcap``."""
    from ground.mcap_io.segments import merge
    from tools.launcher import segment_path

    segments: list[Path] = []
    while segment_path(out, len(segments)).exists():
        segments.append(segment_path(out, len(segments)))
    if not segments:
        return []
    merged = merge(segments, out / "run.mcap.tmp")
    os.replace(out / "run.mcap.tmp", out / "run.mcap")
    print(f"navbank run: the recording's {len(segments)} segments were merged into {out / 'run.mcap'}", file=sys.stderr)
    return [{"file": str(s.path), "messages": s.messages, "complete": s.complete,
             "first_log_unix_s": None if s.first_log_ns is None else s.first_log_ns / 1e9,
             "last_log_unix_s": None if s.last_log_ns is None else s.last_log_ns / 1e9} for s in merged]


def _recorded_by_logger(mcap: Path) -> dict[str, Any]:
    """The logger's closing record in the recording (``navbank.logger`` metadata: its counts of
    duplicates, gaps, ... as JSON texts); empty if there is none."""
    from ground.mcap_io.reader import read_metadata

    try:
        return read_metadata(mcap).get("navbank.logger", {})
    except Exception:  # a recording without the logger's closing record: nothing to add
        return {}


def _restarts_block(restarts: list[Restart], t0: float, logged: dict[str, Any], segments: list[Any],
                    resent: list[int]) -> dict[str, Any]:
    """The summary's ``restarts`` section: the launcher's record of each restart, how many
    measurements the simulator sent again after each FSW restart (``resent``, in order, from its
    status), and the logger's count of what it received twice (dropped) or never (lost):
    ``logged``'s ``duplicates`` and ``gaps`` (tables, or their JSON texts as the recording keeps them)."""

    def table(key: str) -> dict[str, int]:
        value = logged.get(key, {})
        if isinstance(value, str):
            try:
                value = json.loads(value)
            except ValueError:
                return {}
        return {str(k): int(v) for k, v in value.items()} if isinstance(value, dict) else {}

    resent_after = iter(resent)
    events = [{"process": r.process, "exit_code": r.exit_code, "at_unix_s": r.at_unix_s, "at_wall_s": r.at_wall_s,
               "checkpoint_measurements": r.checkpoint_measurements, "checkpoint_t_s": r.checkpoint_t_s,
               "checkpoint_day": None if r.checkpoint_t_s is None else (r.checkpoint_t_s - t0) / 86400.0,
               "resent": next(resent_after, None) if r.process == "fsw" else None}
              for r in restarts]
    return {"events": events, "duplicates_dropped": table("duplicates"), "gaps": table("gaps"), "segments": segments}


def _summary(cfg: ScenarioConfig, seed: int, run_id: str, out: Path, fault: str | None, wall: float,
             status: RunEnding, reason: str | None = None, restarts: list[Restart] | None = None
             ) -> RunSummary | dict[str, Any]:
    """The run's summary from what was recorded: the logger's (:data:`~tools.launcher.LOGGER_SUMMARY`)
    when it recorded the whole run, else from the MCAP read back. A logger that died leaves run.mcap
    without its footer: what it holds is first rewritten into run.recovered.mcap. If nothing
    usable was recorded, a summary of just how the run ended."""
    from ground.mcap_io.reader import is_complete, read_messages, recover
    from ground.mcap_io.reader import summary as mcap_counts
    from ground.report.run_summary import reads_topic, summarize
    from fsw.interface import topics
    from ground.report.summary_types import RestartsBlock, RunFiles
    from sim.resend import RESENT

    mcap = out / "run.mcap"
    init = cfg.fsw.initial_state
    if init is None:
        raise UsageError("the scenario resolved without an a-priori initial state")
    fed = _logger_summary(out / LOGGER_SUMMARY)  # taken whatever happened: summary.json is the run's
    if status != "complete" or restarts:
        fed = None  # a run the logger may not have seen whole (the resend counts are only in the recording)
    messages: list[tuple[str, Any]] = []
    segments: list[Any] = []
    try:
        if fed is not None:
            summary, logged = dataclasses.replace(fed[0], wall_time_s=wall), fed[1]
        else:
            segments = _merge_segments(out)
            if not is_complete(mcap):
                fixed = out / "run.recovered.mcap"
                recover(mcap, fixed)
                print(f"navbank run: {mcap} was left incomplete; what it held is in {fixed}", file=sys.stderr)
                mcap = fixed
            wanted = [t for t in mcap_counts(mcap) if reads_topic(t)]
            messages = [(rec.topic, rec.message) for rec in read_messages(mcap, topics=wanted, sort_in_memory=True)
                        if rec.message is not None]
            summary = summarize(messages, scenario=cfg.name, seed=seed, fault=fault, t0=init.t_s, wall_time_s=wall)
            logged = _recorded_by_logger(mcap) if restarts is not None else {}
    except Exception as exc:  # an interrupted or failed run may have recorded too little to summarise
        if status == "complete":
            raise
        return {"run_id": run_id, "status": status, "reason": reason,
                "summary_error": f"{type(exc).__name__}: {exc}"[:500], "files": {"mcap": str(out / "run.mcap")}}
    # the simulator's resend counts matter only after an FSW restart, which the logger's summary never follows
    resent = [m.counts[RESENT] for t, m in messages if t == "/" + topics.SIM_STATUS and RESENT in m.counts]
    block = None if restarts is None else RestartsBlock.from_json(
        _restarts_block(restarts, init.t_s, logged, segments, resent))
    return dataclasses.replace(summary, run_id=run_id, status=status, reason=reason, restarts=block,
                               files=RunFiles(mcap=str(mcap), config=str(out / "config.yaml")))


def _logger_summary(path: Path) -> tuple[RunSummary, dict[str, Any]] | None:
    """The summary the logger wrote while recording the whole run, with its counts of duplicates
    and gaps (taken, and the file removed: summary.json is the run's); None if there is none to
    trust — then the recording is read back. The logger writes it only once it has finished
    run.mcap, and a file of an earlier run was removed before this one started."""
    from ground.report.summary_types import RunSummary

    if not path.exists():
        return None  # the logger said why (its log)
    try:
        text = path.read_text(encoding="utf-8")
        path.unlink()
        data = json.loads(text)
        logged = data["logger"]
        if not isinstance(logged, dict):
            raise ValueError("its logger section is not an object")
        return RunSummary.from_json(data["summary"]), logged
    except Exception as exc:  # noqa: BLE001 - whatever spoilt it, the recording still holds the truth
        print(f"navbank run: the logger's summary {path} was not usable ({type(exc).__name__}: {exc}); "
              "reading the recording back", file=sys.stderr)
        return None


def _fsw_echo(bar: Any) -> Callable[[str], None]:
    """What the launcher does with each line of the FSW's output: its progress lines move the
    bar (simulated days of the scenario's span), anything else is printed above it."""

    def echo(line: str) -> None:
        progress = fsw_progress(line)
        if progress is None:
            bar.write(line, file=sys.stderr)
        else:
            day, rest = progress
            advance_to(bar, day, rest.removesuffix(" done"))

    return echo


def run(args) -> int:
    from tools.summary import describe

    cfg = with_budget(scenario_from_args(args), args.budget_mode, args.budget, args.cpu_scale)
    if args.max_restarts < 0:
        raise UsageError("--max-restarts must be >= 0")
    if args.rate is not None and not (math.isfinite(args.rate) and args.rate > 0):
        raise UsageError("--rate must be a number > 0")
    if args.checkpoint_every is not None:
        if args.checkpoint_every < 0:
            raise UsageError("--checkpoint-every must be >= 0")
        cfg = dataclasses.replace(cfg, fsw=dataclasses.replace(cfg.fsw, checkpoint=dataclasses.replace(
            cfg.fsw.checkpoint, every_measurements=args.checkpoint_every)))
    cfg, seed = resolve(cfg, args.seed)
    run_id = args.run_id or new_run_id()
    out = Path(args.out or Path("runs") / run_id)
    check_output_dir(out)  # before anything starts: exit 2 for a directory we could not fill
    filters = ", ".join(f.name for f in cfg.fsw.bank.filters)
    print(f"navbank run {run_id}: scenario {cfg.name}, seed {seed}, filters {filters}; output {out}/", file=sys.stderr)
    live = None
    if args.live:
        if not 0 <= args.live_port <= 65535:
            raise UsageError("--live-port must be within 0..65535")
        port = args.live_port or free_tcp_ports(1)[0]
        live = (args.live_host, port)
        print(f"navbank run {run_id}: live view on ws://{args.live_host}:{port} (Foxglove: Open connection, "
              "Foxglove WebSocket)", file=sys.stderr)
    init = cfg.fsw.initial_state
    context = None if init is None else {"scenario": cfg.name, "seed": seed, "fault": args.fault, "t0": init.t_s}
    t0 = time.perf_counter()
    bar = None if args.quiet else progress_bar(cfg.sim.span_days, desc="run", unit="day")
    echo = None if bar is None else _fsw_echo(bar)
    status: RunEnding = "complete"
    reason: str | None = None
    code = 0
    restarts: list[Restart] = []
    try:
        launch(cfg, run_id, out, timeout_s=args.timeout, echo=echo, max_restarts=args.max_restarts, restarts=restarts,
               authenticated=not args.plain_tcp, live=live, rate=args.rate, summary_context=context)
        if bar is not None:
            advance_to(bar, bar.total)  # the last measurement may come a little before the span's end
    except RunFailed as exc:
        status, reason, code = "failed", str(exc), 1
        print(f"navbank run: {exc}", file=sys.stderr)
    except KeyboardInterrupt:
        # the processes were stopped in order (the logger finished its file): say what was done
        status, reason, code = "interrupted", "stopped by SIGINT/SIGTERM", 130
        print("navbank run: interrupted; the processes were stopped", file=sys.stderr)
    except OSError as exc:  # the configuration file, written first (e.g. the disk filled up meanwhile)
        print(f"navbank run: {write_error_line(exc, out / 'config.yaml')}", file=sys.stderr)
        return 1
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    summary = _summary(cfg, seed, run_id, out, args.fault, wall, status, reason,
                       restarts if args.max_restarts > 0 else None)
    try:
        path = write_summary(summary if isinstance(summary, dict) else summary.to_json(), out)
    except OSError as exc:
        if code == 0:
            print(f"navbank run: {write_error_line(exc, out / 'summary.json')}", file=sys.stderr)
            return 1
        return code  # the line that said why the run failed also explains this one (e.g. a full disk)
    if isinstance(summary, dict):
        print(f"navbank run: {status}; nothing recorded could be summarised ({summary['summary_error']}); see {path}",
              file=sys.stderr)
        return code
    print(describe(summary))
    if status != "complete":
        print(f"status: {status} ({reason})")
    print(f"files: {summary.files.mcap if summary.files else out / 'run.mcap'}  {path}  {out / 'config.yaml'}")
    return code

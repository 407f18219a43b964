"""``navbank campaign``: run a fault-injection campaign and compute its statistics."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from tools.campaign.executors import make_executor
from tools.campaign.plan import expand
from tools.campaign.runner import run_campaign, select_tasks
from tools.campaign.spec import builtin_names, load_campaign
from tools.campaign.stats import compute_directory, write_outputs
from tools.campaign.store import read_rows
from tools.commands.errors import UsageError
from tools.commands.outputs import check_output_dir

NAME = "campaign"
HELP = "run a Monte Carlo fault-injection campaign (scenarios x faults x gating networks x seeds)"
DESCRIPTION = """Run a campaign file (or a built-in campaign by name; without one, list them):
every cell of scenarios x fault cases x gating-network variants, with the given seeds, each run
flown in process by a worker. One JSON line per finished run goes to DIR/runs.jsonl (summary,
id, cell, seed, status, error, wall time). Re-running the same command resumes: finished runs
are skipped; --rerun-failed re-runs only the failed ones. At the end (and with --stats-only DIR)
the statistics are recomputed from runs.jsonl into DIR/summary.json and DIR/report.md.
With `keep_mcap: failed|detected|all` in the campaign file, the chosen runs also keep their
recording as DIR/mcap/<id>.mcap (navbank report and navbank replay --rerun read it).

Ctrl-C stops submitting and lets running runs finish (a second Ctrl-C cancels them); the exit
code is then 130. Exit code 1 means some runs failed (see report.md), 2 a configuration error."""


def add_arguments(p) -> None:
    p.add_argument("campaign", nargs="?", metavar="FILE|NAME", help="campaign YAML file or built-in campaign name")
    p.add_argument("--workers", type=int, default=None, metavar="N", help="parallel runs (default: number of cores)")
    p.add_argument("--executor", choices=("local", "dask"), default="local",
                   help="local: spawn process pool (default); dask: a dask.distributed cluster")
    p.add_argument("--scheduler", metavar="ADDR", default=None,
                   help="dask scheduler address (tcp://HOST:PORT); default: a LocalCluster on 127.0.0.1")
    p.add_argument("--out", metavar="DIR", default=None, help="campaign directory (default: ./campaign-NAME)")
    p.add_argument("--rerun-failed", action="store_true", help="re-run only the runs whose last attempt failed")
    p.add_argument("--stats-only", metavar="DIR", default=None,
                   help="recompute summary.json and report.md of an existing campaign directory; run nothing")
    p.add_argument("--dry-run", action="store_true", help="print the cells and how many runs are left; run nothing")
    p.add_argument("--quiet", action="store_true", help="no progress line")


def executor_factory(args):
    """A factory for the chosen executor (started only if there is something to run)."""

    def start():
        try:
            return make_executor(args.executor, args.workers, args.scheduler)
        except (RuntimeError, OSError) as exc:
            raise UsageError(f"cannot start the {args.executor} executor: {exc}") from None

    return start


def _list() -> int:
    print("Built-in campaigns (navbank campaign NAME):")
    for name in builtin_names():
        loaded = load_campaign(name)
        print(f"  {name:<20}  {loaded.config.description}")
    return 0


def _stats(directory: Path) -> int:
    summary = compute_directory(directory)
    s_path, r_path = write_outputs(directory, summary)
    r = summary.runs
    print(f"{directory}: {r.ok} ok, {r.failed} failed"
          + ("" if r.missing is None else f", {r.missing} missing") + f"; wrote {s_path} and {r_path}")
    return 0


def run(args) -> int:
    if args.stats_only:
        d = Path(args.stats_only)
        if not (d / "runs.jsonl").exists():
            raise UsageError(f"{d}: no runs.jsonl (not a campaign directory)")
        check_output_dir(d, "--stats-only")  # summary.json and report.md are written into it
        return _stats(d)
    if not args.campaign:
        return _list()
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be at least 1")
    if args.scheduler and args.executor != "dask":
        raise UsageError("--scheduler needs --executor dask")
    loaded = load_campaign(args.campaign)
    plan = expand(loaded)
    out = Path(args.out) if args.out else Path(f"campaign-{plan.name}")
    if args.dry_run:
        latest = read_rows(out / "runs.jsonl").latest()
        todo = select_tasks(plan, latest, args.rerun_failed)
        for cell in plan.cells:
            n = sum(1 for t in plan.tasks if t.cell == cell)
            left = sum(1 for t in todo if t.cell == cell)
            print(f"{cell.key}: {n} runs, {left} to do")
        print(f"{len(plan.tasks)} runs in {len(plan.cells)} cells; {len(todo)} to do into {out}")
        return 0
    check_output_dir(out)  # before any run: exit 2 for a directory we could not fill
    (out / "campaign.yaml").write_text(loaded.text, encoding="utf-8")
    outcome = run_campaign(plan, out, executor_factory(args), rerun_failed=args.rerun_failed, quiet=args.quiet)
    summary = compute_directory(out)
    s_path, r_path = write_outputs(out, summary)
    msg = (f"campaign {plan.name}: {outcome.finished} run(s) this time ({outcome.failed} failed), "
           f"{outcome.skipped} already done, {len(plan.tasks)} planned; "
           + (f"{outcome.runs_per_min:.2f} runs/min with {outcome.workers} {outcome.executor} worker(s)"
              if outcome.finished else ("nothing to run" if not outcome.submitted else "no run finished")))
    if outcome.repaired_bytes:
        msg += f"; cut a torn last line ({outcome.repaired_bytes} bytes) from runs.jsonl"
    print(msg, file=sys.stderr)
    print(json.dumps({"out": str(out), "finished": outcome.finished, "failed": outcome.failed,
                      "skipped": outcome.skipped, "cancelled": outcome.cancelled, "interrupted": outcome.interrupted,
                      "runs_per_min": round(outcome.runs_per_min, 3), "workers": outcome.workers,
                      "executor": outcome.executor, "summary": str(s_path), "report": str(r_path)}))
    if outcome.interrupted:
        print("navbank campaign: interrupted; run the same command again to resume", file=sys.stderr)
        return 130
    return 1 if summary.runs.failed else 0

"""Campaign-throughput rows of ``navbank bench``: runs per minute on 1 and 2 workers.

One small nominal campaign of the default scenario (``insight-approach``, fault case ``none``,
3 runs per worker; 4 on ``--quick``'s short arcs) is run by :func:`tools.campaign.runner.run_campaign` — the code
``navbank campaign`` runs — on:

* the local spawn pool with 1 worker (``r1``) and with 2 workers;
* a dask ``LocalCluster`` with 2 workers;
* a real dask cluster: ``dask scheduler`` and two ``dask worker`` processes on loopback
  (:class:`tools.campaign.dask_cluster.LoopbackCluster`), reached by address like any existing one.

Rows: ``campaign-gain-<executor>``: ours = runs/min with 2 workers, reference = r1, ratio = what
the added worker adds relative to one worker (goal ≥ 0.85); ``campaign-45day-runs-per-min``: the
2-worker local pool's rate in full 45-day runs per minute (runs of a shorter arc are converted
by their length) against the goal figure of 60; ``campaign-worker-overhead``: the CPU of a run
as a campaign task (median, 1 worker) against the CPU of the same arc's run in process (what
being a task adds per run: decoding the task, building the row, pickling; goal ≥ 0.9).

Each configuration is measured ``repeats`` times (2; 1 on ``--quick``), the 1- and 2-worker local
pools alternately, and its row keeps the best rate (``runs_per_min_repeats`` lists them all), as
the other rows keep the best of their repeats. One measurement (~14 s) on a 2-core machine that
also runs the scheduler, the client and whatever else is there scatters: three bench runs one
after the other gave the dask scheduler's gain 0.92, 0.84 and 0.74 (the local pool's 0.95, 0.93,
0.90), while a campaign on that cluster measured alone showed its scheduler using 1.8 % of a core
and its workers 4.55-4.60 s of CPU per 45-day run, the local pool's runs 4.49-4.55 s.

Each rate is the steady state of warm workers: the executor first runs one short priming run
per worker (which starts and warms it, :mod:`tools.campaign.warm`; its time is the detail
``start_s``, paid once per campaign), then the rate counts from submitting the first measured
run to storing the last row, which includes what an executor adds once per campaign (dask's first
task and last result cross its scheduler: ~0.5 s in 10 s of 45-day runs, two per worker, where
the local pool's rate and dask's agreed within 2-4 % at three per worker). The machine may be
shared: rates are wall-clock, so other load lowers them — where the kernel shares CPU per session (autogroup), a campaign's processes share
one session's part however many workers it has. The detail ``cpu_gain`` (from the runs' CPU
times, :func:`cpu_gain`) says what the second worker would add with a core of its own.
"""

from __future__ import annotations

import itertools
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tools.bench.rows import Goal, make_row, skipped_row
from tools.campaign.executors import DaskExecutor, Executor, LocalExecutor
from tools.campaign.plan import CampaignPlan, expand
from tools.campaign.runner import run_campaign
from tools.campaign.spec import load_campaign
from tools.campaign.store import read_rows

GAIN_GOAL = Goal("gain", ">=", 0.85)
RATE_GOAL = Goal("rate", ">=", 1.0)
OVERHEAD_GOAL = Goal("cost", ">=", 0.9)
RUNS_PER_MIN_GOAL = 60.0
FULL_SPAN_DAYS = 45.0
PRIME_SPAN_DAYS = 0.25  # the priming runs: one per worker, to start and warm it


def campaign_text(span_days: float, runs: int, base_seed: int = 1) -> str:
    """A nominal campaign of the default scenario over ``span_days``, ``runs`` seeds."""
    return (f"name: bench\ndescription: navbank bench throughput\nseeds: {{count: {runs}, base: {base_seed}}}\n"
            f"overrides:\n  sim.trajectory.span_days: {span_days}\n"
            "matrix:\n  - scenarios: [insight-approach]\n    faults: [none]\n")


def plan_for(span_days: float, runs: int, directory: Path, base_seed: int = 1) -> CampaignPlan:
    path = directory / f"bench-{runs}-{base_seed}.yaml"
    path.write_text(campaign_text(span_days, runs, base_seed), encoding="utf-8")
    return expand(load_campaign(str(path)))


def measure(factory: Callable[[], Executor], plan: CampaignPlan, prime: CampaignPlan, out: Path) -> dict[str, Any]:
    """Runs per minute of ``plan`` on a fresh executor from ``factory`` once its workers are up:
    the executor first runs ``prime`` (one short run per worker), which starts and warms every
    worker; ``start_s`` is how long that took."""
    t0 = time.perf_counter()
    executor = factory()
    try:
        primed = run_campaign(prime, out / "prime", executor, quiet=True)
        start_s = time.perf_counter() - t0
        outcome = run_campaign(plan, out / "runs", executor, quiet=True)
    finally:
        executor.close()
    if primed.failed or outcome.failed or outcome.finished != len(plan.tasks):
        raise RuntimeError(f"{outcome.failed} of {len(plan.tasks)} bench runs failed ({outcome.failed_ids[:3]})")
    cpu = [r.cpu_time_s for r in read_rows(out / "runs" / "runs.jsonl").rows if r.cpu_time_s is not None]
    return {"runs_per_min": outcome.runs_per_min, "runs": outcome.finished, "wall_s": outcome.wall_s,
            "workers": outcome.workers, "executor": outcome.executor, "start_s": start_s,
            "run_cpu_s": statistics.median(cpu) if cpu else None}


def cpu_gain(one: dict[str, Any], two: dict[str, Any]) -> float | None:
    """What the second worker would add with a core to itself: 2 × (run CPU on 1 worker / run CPU
    on 2) − 1. It tells whether the runs themselves slow down side by side (memory, caches),
    which wall-clock rates cannot when other load on the machine takes the second core."""
    c1, c2 = one.get("run_cpu_s"), two.get("run_cpu_s")
    return 2.0 * c1 / c2 - 1.0 if c1 and c2 else None


def best_of(measured: list[dict[str, Any]]) -> dict[str, Any]:
    """The measurement of highest rate among repeats of one configuration, with every repeat's
    rate (``runs_per_min_repeats``, in the order measured)."""
    best = max(measured, key=lambda x: x["runs_per_min"])
    return {**best, "runs_per_min_repeats": [x["runs_per_min"] for x in measured]}


def campaign_rows(span_days: float, inprocess_cpu_s: float | None = None, runs_per_worker: int = 3,
                  dask: bool = True, repeats: int = 2) -> list[dict[str, Any]]:
    """The campaign rows (see the module docstring). ``inprocess_cpu_s``: the CPU of one in-process
    run over the same arc (:func:`tools.inprocess.run_in_process`), for the worker-overhead row."""
    rows: list[dict[str, Any]] = []
    common = {"span_days": span_days, "scenario": "insight-approach", "runs_per_worker": runs_per_worker,
              "repeats": repeats}
    with tempfile.TemporaryDirectory(prefix="navbank-bench-campaign-") as tmp:
        d = Path(tmp)
        bases = itertools.count(100, 100)
        dirs = itertools.count()

        def plan(workers: int) -> tuple[CampaignPlan, CampaignPlan]:
            """The measured plan and its priming plan; distinct seeds per measurement."""
            base = next(bases)
            return (plan_for(span_days, workers * runs_per_worker, d, base),
                    plan_for(PRIME_SPAN_DAYS, workers, d, base + 50))

        def repeated(factory: Callable[[], Executor], workers: int, label: str) -> dict[str, Any]:
            return best_of([measure(factory, *plan(workers), d / f"{label}-{next(dirs)}") for _ in range(repeats)])

        ones, twos = [], []
        for _ in range(repeats):  # alternately, so that a slow spell of the machine hits both alike
            ones.append(measure(lambda: LocalExecutor(1), *plan(1), d / f"local-1-{next(dirs)}"))
            twos.append(measure(lambda: LocalExecutor(2), *plan(2), d / f"local-2-{next(dirs)}"))
        one, two = best_of(ones), best_of(twos)
        r1 = one["runs_per_min"]
        rows.append(make_row("campaign-gain-local", two["runs_per_min"], r1, "runs/min", GAIN_GOAL,
                             "(2-worker rate / 1-worker rate) - 1: what the added worker adds (local spawn pool)",
                             one_worker=one, two_workers=two, cpu_gain=cpu_gain(one, two), **common))
        rate45 = two["runs_per_min"] * span_days / FULL_SPAN_DAYS
        rows.append(make_row("campaign-45day-runs-per-min", rate45, RUNS_PER_MIN_GOAL, "runs/min", RATE_GOAL,
                             "45-day runs per minute on 2 local workers / goal figure 60",
                             converted_from_span_days=span_days if span_days != FULL_SPAN_DAYS else None, **common))
        if inprocess_cpu_s and one.get("run_cpu_s"):
            rows.append(make_row("campaign-worker-overhead", one["run_cpu_s"], inprocess_cpu_s, "s CPU/run",
                                 OVERHEAD_GOAL, "CPU of the run in process / CPU of the same run as a campaign task "
                                 "(what being a task adds per run: decoding, row, pickling)", **common))
        if not dask:
            return rows
        try:
            lc = repeated(lambda: DaskExecutor(2), 2, "dask-lc")
            rows.append(make_row("campaign-gain-dask-localcluster", lc["runs_per_min"], r1, "runs/min", GAIN_GOAL,
                                 "(2-worker LocalCluster rate / 1 local worker's rate) - 1", two_workers=lc,
                                 cpu_gain=cpu_gain(one, lc), **common))
        except RuntimeError as exc:
            rows.append(skipped_row("campaign-gain-dask-localcluster", "runs/min", GAIN_GOAL, str(exc).splitlines()[0]))
        try:
            from tools.campaign.dask_cluster import LoopbackCluster

            t0 = time.perf_counter()
            with LoopbackCluster(2) as cluster:
                cluster_start_s = time.perf_counter() - t0
                sc = repeated(lambda: DaskExecutor(2, cluster.address), 2, "dask-sched")
            rows.append(make_row("campaign-gain-dask-scheduler", sc["runs_per_min"], r1, "runs/min", GAIN_GOAL,
                                 "(rate on dask scheduler + 2 dask worker processes / 1 local worker's rate) - 1",
                                 two_workers=sc, cluster_start_s=cluster_start_s, cpu_gain=cpu_gain(one, sc), **common))
        except (RuntimeError, TimeoutError, OSError) as exc:
            rows.append(skipped_row("campaign-gain-dask-scheduler", "runs/min", GAIN_GOAL, str(exc).splitlines()[0]))
    return rows


__all__ = ["best_of", "campaign_rows", "campaign_text", "plan_for", "measure"]

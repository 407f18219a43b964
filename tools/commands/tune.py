"""``navbank tune``: tune a filter bank on a post-processed measurement set.

    navbank tune ga [--mcap RUN.mcap | --data-seed N] [--eta 1] [--workers N] [--out DIR]
    navbank tune em RUN.mcap [--split-day D] [--epsilon E] [--out DIR]

``ga`` — Chaer et al. 1997 §VII–VIII: a bank of --population filters of the linear tracking example
(α = [q1 q2 r1 r2], each coded in --bits bits on --interval by eq. 33) processes the whole
measurement set; the `moe` gate's weights after the last measurement are the fitness; roulette
selection, crossover at parameter boundaries, mutation and elitism make the next bank; it stops
when the filters of non-negligible weight agree within --epsilon, or after --max-iterations.
The set is the ``generic-linear`` measurements of a recording (--mcap) or a simulated Experiment 4
set (truth α* = [4.31 22.45 24.01 11.42], --length measurements). Each generation's bank is
processed in --workers pieces (local processes, or dask with --executor dask / --scheduler).
Writes DIR/ga.json (every generation) and DIR/ga-clusters.png (the Fig. 15 analogue) and prints
Table VII's rows.

``em`` — Chaer et al. 1998 §IV: the recorded run's measurements are re-run through its recorded FSW
(as `navbank replay --rerun` does) to recompute every filter's residual log-density; the set is split
where the online hierarchical gate's top-level lead changes for good (or at --split-day), and EM
with IRLS solves each segment's top-level and in-bank gate parameters until the L1 change of the
weights is below --epsilon. Writes DIR/em.json and DIR/em-weights.png (online against EM weights).

Exit codes: 0 done (converged or not), 2 bad arguments or input.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from tools.commands.errors import UsageError
from tools.commands.outputs import check_output_dir

NAME = "tune"
HELP = "tune a filter bank on post-processed measurements (GA of Chaer et al. 1997, EM of Chaer et al. 1998)"
DESCRIPTION = __doc__.split("\n", 2)[2] if __doc__ else HELP


def add_arguments(p) -> None:
    sub = p.add_subparsers(dest="method", metavar="METHOD")
    g = sub.add_parser("ga", help="genetic algorithm over the bank (Chaer et al. 1997 §VIII)", description=DESCRIPTION)
    src = g.add_mutually_exclusive_group()
    src.add_argument("--mcap", metavar="FILE", default=None, help="recording whose generic-linear measurements to process")
    src.add_argument("--data-seed", type=int, default=0, metavar="N", help="seed of the simulated Experiment 4 set (default 0)")
    g.add_argument("--length", type=int, default=200, metavar="K", help="measurements of the simulated set (default 200)")
    g.add_argument("--seed", type=int, default=1000, metavar="N", help="seed of the GA (default 1000)")
    g.add_argument("--population", type=int, default=20, metavar="P", help="filters in the bank (default 20)")
    g.add_argument("--bits", type=int, default=10, metavar="L", help="bits per parameter (default 10)")
    g.add_argument("--interval", type=float, nargs=2, default=(1.0, 50.0), metavar=("A", "B"),
                   help="search interval [a, b] of every parameter (default 1 50)")
    g.add_argument("--eta", type=float, default=1.0, help="learning rate of the gate (default 1, the paper's)")
    g.add_argument("--epsilon", type=float, default=2.0, help="convergence tolerance (default 2)")
    g.add_argument("--max-iterations", type=int, default=30, metavar="N", help="(default 30)")
    g.add_argument("--crossover", type=float, default=0.9, metavar="P", help="crossover probability (default 0.9)")
    g.add_argument("--mutation", type=float, default=0.02, metavar="P", help="mutation probability per bit (default 0.02)")
    g.add_argument("--workers", type=int, default=1, metavar="N", help="processes re-processing each generation (default 1)")
    g.add_argument("--executor", choices=("local", "dask"), default="local",
                   help="local: spawn process pool (default); dask: a dask.distributed cluster")
    g.add_argument("--scheduler", metavar="ADDR", default=None, help="dask scheduler address (tcp://HOST:PORT)")
    g.add_argument("--out", metavar="DIR", default="tune-ga", help="output directory (default ./tune-ga)")
    g.add_argument("--quiet", action="store_true", help="no progress bar")
    e = sub.add_parser("em", help="EM with IRLS for the hierarchical gate on a recording (Chaer et al. 1998 §IV)",
                       description=DESCRIPTION)
    e.add_argument("mcap", metavar="RUN.mcap", help="recording of a run with a hierarchical gating network")
    e.add_argument("--split-day", type=float, default=None, metavar="D",
                   help="split the set D days after its first measurement (default: at the online gate's switch)")
    e.add_argument("--epsilon", type=float, default=1e-4, help="L1 change of the weights that stops EM (default 1e-4)")
    e.add_argument("--max-iterations", type=int, default=5000, metavar="N", help="(default 5000)")
    e.add_argument("--out", metavar="DIR", default="tune-em", help="output directory (default ./tune-em)")


def _settings(args):
    from ground.tuning import ga

    try:
        coding = ga.Coding(lower=args.interval[0], upper=args.interval[1], bits=args.bits, n_params=4)
        settings = ga.GaSettings(population=args.population, crossover_probability=args.crossover,
                                 mutation_probability=args.mutation, epsilon=args.epsilon,
                                 max_iterations=args.max_iterations)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if not args.eta > 0.0:
        raise UsageError("--eta must be positive")
    if args.workers < 1:
        raise UsageError("--workers must be at least 1")
    return coding, settings


def _measurements(args) -> np.ndarray:
    from ground.mcap_io.reader import McapReadError
    from ground.tuning.measurement_set import linear_measurements
    from tools.validation.chaer1997_ga import experiment_4

    if args.mcap is None:
        if args.length < 2:
            raise UsageError("--length must be at least 2")
        return experiment_4(args.data_seed, args.length)
    try:
        return linear_measurements(args.mcap)
    except (OSError, McapReadError, ValueError) as exc:
        raise UsageError(f"cannot read measurements: {exc}") from None


def run_ga(args) -> int:
    from ground.report.figure import PlottingUnavailable
    from tools.campaign.pool_map import PoolMap
    from tools.progress import advance_to, progress_bar
    from tools.validation.chaer1997_ga import PAPER_OPTIMAL, plot_clusters, run_one

    coding, settings = _settings(args)
    z = _measurements(args)
    out = Path(args.out)
    check_output_dir(out)
    bar = progress_bar(settings.max_iterations, desc="tune ga", unit="iterations", disable=args.quiet)

    def shown(g) -> None:
        advance_to(bar, g.iteration, f"best {np.round(g.best, 2).tolist()} w {g.fitness.max():.2f}, "
                                     f"spread {g.spread.max():.1f}")

    try:
        with PoolMap(args.executor, args.workers, args.scheduler) as pool:
            run = run_one(z, args.eta, args.seed, data_seed=-1 if args.mcap else args.data_seed, settings=settings,
                          coding=coding, mapper=pool, chunks=pool.chunks, on_generation=shown)
    except (RuntimeError, OSError) as exc:
        raise UsageError(f"cannot start the {args.executor} executor: {exc}") from None
    finally:
        bar.close()
    record = {"source": args.mcap or f"simulated Experiment 4, seed {args.data_seed}", "measurements": len(z),
              **run.as_dict()}
    (out / "ga.json").write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    try:
        fig = plot_clusters(run, out / "ga-clusters.png")
    except PlottingUnavailable as exc:
        fig = None
        print(f"navbank tune: {exc}; no figure", file=sys.stderr)
    res = run.result
    state = "converged" if res.converged else "not converged"
    print(f"{len(res.generations)} iterations, {state} (ε = {settings.epsilon:g})")
    print(f"{'α = [q1 q2 r1 r2]':34s}  value                          log-likelihood of the set")
    rows = (("optimal α* (Chaer et al. 1997)", np.array(PAPER_OPTIMAL), run.loglik["truth"]),
            ("max. likelihood α̂ of this set", run.ml, run.loglik["ml"]),
            ("best, 1st iteration", res.generations[0].best, run.loglik["best_first"]),
            (f"best, iteration {len(res.generations)}", res.final.best, run.loglik["best_final"]))
    for label, v, ll in rows:
        print(f"{label:34s}  [{' '.join(f'{x:6.2f}' for x in v)}]  {ll:10.2f}")
    print(f"wrote {out / 'ga.json'}" + (f" and {fig}" if fig else ""))
    return 0


def run_em(args) -> int:
    from fsw.interface.yamlconfig import ConfigError
    from ground.mcap_io.reader import McapReadError
    from ground.report.figure import PlottingUnavailable
    from ground.tuning.em_irls import LikelihoodDecreased
    from ground.tuning.recorded_residuals import recorded_hierarchy, switch_index
    from ground.tuning.segment_em import fit_segments
    from tools.validation.chaer1998_em import DAY_S, plot_em

    if not (args.epsilon > 0.0):
        raise UsageError("--epsilon must be positive")
    if args.max_iterations < 1:
        raise UsageError("--max-iterations must be at least 1")
    out = Path(args.out)
    check_output_dir(out)
    try:
        data = recorded_hierarchy(args.mcap)
    except (OSError, McapReadError, ValueError, ConfigError) as exc:
        raise UsageError(f"cannot re-run {args.mcap}: {exc}") from None
    if args.split_day is None:
        split = switch_index(data.online_top)
    else:
        split = int(np.searchsorted(data.t_s, data.t_s[0] + args.split_day * DAY_S))
        if not 0 < split < len(data.t_s):
            raise UsageError(f"--split-day {args.split_day:g} is outside the recorded measurements")
    try:
        fits = fit_segments(data, split, epsilon=args.epsilon, max_iterations=args.max_iterations)
    except LikelihoodDecreased as exc:
        print(f"navbank tune: EM failed: {exc}", file=sys.stderr)
        return 1
    record = {"source": str(args.mcap), "measurements": len(data.t_s), "split": split, "banks": data.bank_filters,
              "segments": [f.as_dict(data) for f in fits]}
    (out / "em.json").write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    try:
        fig = plot_em(data, fits, out / "em-weights.png")
    except PlottingUnavailable as exc:
        fig = None
        print(f"navbank tune: {exc}; no figure", file=sys.stderr)
    where = "no switch found" if split is None else f"split at point {split}, day {(data.t_s[split] - data.t_s[0]) / DAY_S:.1f}"
    print(f"{len(data.t_s)} measurements re-run; {where}")
    for k, f in enumerate(fits):
        ll = f.result.log_likelihood
        state = "converged" if f.result.converged else "not converged"
        print(f"segment {k + 1} [{f.start}, {f.stop}): {f.result.iterations} EM iterations ({state}), "
              f"log-likelihood {ll[0]:.1f} -> {ll[-1]:.1f}")
        print("  top: " + ", ".join(f"{b} {w:.3f}" for b, w in zip(data.banks, f.top)))
        for i, b in enumerate(data.banks):
            print(f"  {b}: " + ", ".join(f"{n} {w:.3f}" for n, w in zip(data.bank_filters[b], f.in_bank[i])))
    print(f"wrote {out / 'em.json'}" + (f" and {fig}" if fig else ""))
    return 0


def run(args) -> int:
    method = getattr(args, "method", None)
    if method == "ga":
        return run_ga(args)
    if method == "em":
        return run_em(args)
    raise UsageError("choose a method: navbank tune ga|em (see navbank tune --help)")

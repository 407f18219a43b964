"""``navbank calibrate``: calibrate the anomaly detector on nominal runs to a target false-alarm rate.

Procedure (this is how the calibrated values in the built-in scenarios are reproduced)::

    navbank calibrate --scenario insight-approach --network chi2 --seeds 200 --target-fa 0.01 \\
        --out detector-chi2.yaml --write-scenario insight-approach-calibrated.yaml

1. Nominal runs. The scenario's faults are replaced by the ``none`` preset, the detector is
   switched off (it only watches the weights; a calibration already in the scenario plays no
   part) and ``--network`` is added to the gating list if absent. Seeds ``--base-seed`` …
   ``--base-seed + N − 1`` are flown through the campaign machinery (same workers, executors,
   resume and failure handling as ``navbank campaign``; the runs go to ``--runs-dir``). The
   default base seed 1001 keeps calibration seeds apart from the seeds campaigns use (1, 2, …),
   so a campaign's false-alarm rate on ``none`` cases is an out-of-sample check.
2. Weight histories. Each worker keeps only the FilterWeights of ``--network`` (topic
   ``fsw/weights/<network>``) and sends back one (batches x filters) array with the batch epochs;
   they are stored as ``RUNS_DIR/weights/<id>.npz``.
3. Calibration: :func:`tools.calibration.thresholds.calibrate` on those arrays (its module docstring gives
   the statistics: nominal band, k-of-n critical values, empirical or Gumbel threshold, hysteresis
   and onset reference) with ``--target-fa`` per run (or per ``--segment-batches`` segment),
   ``--warmup``, ``--persistence K N``, ``--hold`` and ``--statistic``.
4. Output: the :class:`~fsw.fdir.config.DetectorConfig` as YAML (``--out``), optionally a copy of
   the scenario with ``fsw.detector`` set to this network and calibration
   (``--write-scenario``), and the calibration report on stdout: threshold, achieved in-sample
   false-alarm rate with its Clopper–Pearson interval, number of runs (units) and batches.

Re-running the same command reuses the runs already in ``--runs-dir``; more ``--seeds`` adds
runs. Exit codes: 0 done, 1 no usable nominal run or the calibration failed, 2 a configuration
error, 130 interrupted (nothing written).
"""

from __future__ import annotations

import dataclasses
import shlex
import sys
from pathlib import Path

import numpy as np

from fsw.config import DetectorSection, GatingEntry
from fsw.fdir.config import config_to_yaml
from fsw.interface.yamlconfig import dump_yaml, load_text
from tools.calibration.thresholds import CalibrationError, CalibrationReport, calibrate, false_alarm_prediction_interval
from tools.campaign.plan import expand
from tools.campaign.runner import run_campaign
from tools.campaign.spec import CampaignConfig, FaultCase, LoadedCampaign, MatrixBlock, NetworkVariant, SeedPlan
from tools.campaign.store import has_weights, load_weights, read_rows
from tools.commands.campaign import executor_factory
from tools.commands.errors import UsageError
from tools.commands.outputs import check_output_dir, check_output_file
from tools.scenario import ScenarioConfig, load_scenario

NAME = "calibrate"
HELP = "calibrate the anomaly detector on nominal runs to a target false-alarm rate"
DESCRIPTION = __doc__.split("\n", 2)[2] if __doc__ else HELP


def add_arguments(p) -> None:
    p.add_argument("--scenario", default="insight-approach", metavar="S", help="built-in scenario or YAML file")
    p.add_argument("--network", action="append", default=None, metavar="NET",
                   help="gating network the detector watches (default chi2); repeat to calibrate several "
                        "networks on the same nominal runs (then --out-dir)")
    p.add_argument("--seeds", type=int, default=40, metavar="N", help="number of nominal runs (default 40)")
    p.add_argument("--base-seed", type=int, default=1001, metavar="B", help="first seed (default 1001)")
    p.add_argument("--target-fa", type=float, default=0.01, help="false-alarm probability per run or segment")
    p.add_argument("--warmup", type=int, default=0, metavar="B", help="batches ignored at the start of each run")
    p.add_argument("--segment-batches", type=int, default=None, metavar="B",
                   help="false-alarm rate per segment of B batches instead of per run")
    p.add_argument("--persistence", type=int, nargs=2, default=(3, 5), metavar=("K", "N"),
                   help="declare when K of the last N batches exceed the threshold (default 3 5)")
    p.add_argument("--hold", type=int, default=5, help="batches below the clear threshold to clear (default 5)")
    p.add_argument("--statistic", choices=("mahalanobis", "max-z"), default="mahalanobis")
    p.add_argument("--workers", type=int, default=None, metavar="N", help="parallel runs (default: cores)")
    p.add_argument("--executor", choices=("local", "dask"), default="local")
    p.add_argument("--scheduler", metavar="ADDR", default=None, help="dask scheduler address")
    p.add_argument("--runs-dir", metavar="DIR", default=None,
                   help="where the nominal runs go (default ./calibrate-SCENARIO-NETWORK); reused on re-runs")
    p.add_argument("--out", metavar="FILE.yaml", default=None, help="detector configuration (default: stdout)")
    p.add_argument("--out-dir", metavar="DIR", default=None,
                   help="write DIR/detector-NETWORK.yaml for every --network (needed with several networks)")
    p.add_argument("--write-scenario", metavar="FILE", default=None,
                   help="also write the scenario with fsw.detector set to this calibration")
    p.add_argument("--quiet", action="store_true", help="no progress line")


def nominal_campaign(scenario_ref: str, network: str | list[str] | tuple[str, ...], seeds: int,
                     base_seed: int) -> LoadedCampaign:
    """The campaign of step 1: ``none`` x the scenario, detector off, every network in the gating
    list and its weight history kept."""
    networks = (network,) if isinstance(network, str) else tuple(network)
    label = "+".join(networks)
    variant = NetworkVariant(name=label, detector=networks[0], overrides={"fsw.detector.calibration": None})
    cfg = CampaignConfig(
        name=f"calibrate-{label}",
        description=f"nominal runs for the {', '.join(networks)} detector calibration",
        matrix=(MatrixBlock(scenarios=(scenario_ref,), faults=(FaultCase(preset="none"),), networks=(variant,)),),
        seeds=SeedPlan(count=seeds, base=base_seed),
        keep_weights=networks,
    )
    return LoadedCampaign(cfg, f"<calibrate {scenario_ref}>", Path.cwd())


def collect_histories(runs_dir: Path, ids: list[str], network: str) -> tuple[list[np.ndarray], tuple[str, ...], list[str]]:
    """``network``'s weight arrays of the successful runs among ``ids`` (their filter order must agree)."""
    latest = read_rows(runs_dir / "runs.jsonl").latest()
    histories, names, used = [], None, []
    for rid in ids:
        row = latest.get(rid)
        if row is None or row.status != "ok":
            continue
        if not has_weights(runs_dir, rid, network):
            continue
        data = load_weights(runs_dir, rid, network)
        filters = data.filters
        if data.weights.size == 0:
            continue  # the network published nothing (a run shorter than one batch)
        if names is None:
            names = filters
        elif filters != names:
            raise CalibrationError(f"run {rid}: filters {filters} differ from {names}")
        histories.append(np.asarray(data.weights, dtype=float))
        used.append(rid)
    return histories, names or (), used


def calibrated_scenario(base: ScenarioConfig, network: str, detector) -> ScenarioConfig:
    gating = base.fsw.gating
    if not any(g.network == network for g in gating):
        gating = (*gating, GatingEntry.of(network))
    section = DetectorSection(network=network, calibration=detector)
    return dataclasses.replace(base, fsw=dataclasses.replace(base.fsw, gating=gating, detector=section))


def format_report(r: CalibrationReport, runs: int, runs_planned: int) -> str:
    lvl = int(round(100 * r.confidence_level))
    unit = "run" if r.units == runs else "segment"
    cut = "" if unit == "run" else f" cut into {r.units} segments"
    rank = ""
    if r.rank:
        suffix = "th" if 10 <= r.rank % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(r.rank % 10, "th")
        rank = f", the {r.rank}{suffix} largest of {r.units} critical values"
    lines = [
        f"detector calibration for network {r.network}: {runs} nominal runs"
        + ("" if runs == runs_planned else f" (of {runs_planned} planned)")
        + f"{cut}, {r.batches} batches after warm-up",
        f"  threshold        {r.threshold:.6g}  ({r.method}{rank})",
        f"  clear threshold  {r.clear_threshold:.6g}",
        f"  onset reference  {r.onset_reference:.6g}",
        f"  target FA        {r.target_fa:g} per {unit}; expected for a fresh {unit} {r.expected_fa:.4g}",
        f"  achieved FA      {r.false_alarms}/{r.units} = {r.fa_rate:.4g} per {unit} "
        f"({lvl} % Clopper-Pearson [{r.fa_ci[0]:.4g}, {r.fa_ci[1]:.4g}]), in sample",
        f"  batches above threshold {r.batch_exceedance:.4g}",
        "  nominal weight std " + ", ".join(f"{s:.4g}" for s in r.nominal_std),
    ]
    lo, hi = false_alarm_prediction_interval(r, 100)
    lines.append(f"  expected false alarms in 100 fresh nominal {unit}s: {lo} to {hi} ({lvl} % prediction interval)")
    return "\n".join(lines)


def reproduce_command(args, network: str) -> str:
    """The command line that recomputes this calibration (for the header of --write-scenario)."""
    parts = ["navbank", "calibrate", "--scenario", args.scenario, "--network", network,
             "--seeds", str(args.seeds), "--base-seed", str(args.base_seed), "--target-fa", f"{args.target_fa:g}",
             "--warmup", str(args.warmup), "--persistence", *map(str, args.persistence), "--hold", str(args.hold),
             "--statistic", args.statistic]
    if args.segment_batches is not None:
        parts += ["--segment-batches", str(args.segment_batches)]
    return " ".join(shlex.quote(p) for p in parts)


def run(args) -> int:
    networks = list(dict.fromkeys(args.network or ["chi2"]))
    if args.seeds < 1:
        raise UsageError("--seeds must be at least 1")
    if not 0.0 < args.target_fa < 1.0:
        raise UsageError("--target-fa must lie in (0, 1)")
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be at least 1")
    if len(networks) > 1 and (args.out or args.write_scenario):
        raise UsageError("with several --network use --out-dir (--out and --write-scenario take one network)")
    base = load_scenario(args.scenario)
    loaded = nominal_campaign(args.scenario, networks, args.seeds, args.base_seed)
    plan = expand(loaded)
    label = "+".join(networks)
    runs_dir = Path(args.runs_dir) if args.runs_dir else Path(f"calibrate-{base.name}-{label}")
    # every output proven writable before the nominal runs (exit 2 otherwise); the runs
    # directory, often the default one, last: a bad option then leaves nothing behind
    if args.out_dir:
        check_output_dir(args.out_dir, "--out-dir")
    if args.out:
        check_output_file(args.out)
    if args.write_scenario:
        check_output_file(args.write_scenario, "--write-scenario")
    check_output_dir(runs_dir, "--runs-dir")
    outcome = run_campaign(plan, runs_dir, executor_factory(args), quiet=args.quiet)
    if outcome.interrupted:
        print("navbank calibrate: interrupted; nothing written (run the same command again to resume)", file=sys.stderr)
        return 130
    if args.out_dir:
        Path(args.out_dir).mkdir(parents=True, exist_ok=True)
    status = 0
    for network in networks:
        status = max(status, _calibrate_one(args, base, plan, runs_dir, network))
    return status


def _calibrate_one(args, base: ScenarioConfig, plan, runs_dir: Path, network: str) -> int:
    try:
        histories, filters, used = collect_histories(runs_dir, [t.id for t in plan.tasks], network)
    except CalibrationError as exc:
        print(f"navbank calibrate: {exc}", file=sys.stderr)
        return 1
    failed = len(plan.tasks) - len(used)
    if failed:
        print(f"navbank calibrate: {failed} nominal run(s) failed, missing or without {network} weights "
              f"(see {runs_dir}/runs.jsonl); "
              f"calibrating on {len(used)}", file=sys.stderr)
    if not histories:
        print(f"navbank calibrate: no successful nominal run to calibrate {network} on", file=sys.stderr)
        return 1
    try:
        detector, report = calibrate(
            histories, args.target_fa, network=network, filters=filters, statistic=args.statistic,
            persistence=tuple(args.persistence), hold=args.hold, warmup=args.warmup,
            segment_batches=args.segment_batches,
        )
    except CalibrationError as exc:
        print(f"navbank calibrate: calibration of {network} failed: {exc}", file=sys.stderr)
        return 1
    command = reproduce_command(args, network)
    text = config_to_yaml(detector)
    out = args.out or (str(Path(args.out_dir) / f"detector-{network}.yaml") if args.out_dir else None)
    if out:
        Path(out).write_text(f"# reproduce: {command}\n" + text, encoding="utf-8")
    else:
        print(text, end="")
    if args.write_scenario:
        scen = calibrated_scenario(base, network, detector)
        header = (f"# {scen.name} with the {network} detector calibrated on {len(used)} nominal runs "
                  f"(seeds {args.base_seed}..{args.base_seed + args.seeds - 1}, target FA {args.target_fa:g})\n")
        header += f"# reproduce: {command}\n"
        body = dump_yaml(scen, drop_defaults=True)
        load_text(ScenarioConfig, body, args.write_scenario)  # what we write must load back
        Path(args.write_scenario).write_text(header + body, encoding="utf-8")
    print(format_report(report, len(used), len(plan.tasks)), file=sys.stdout if out else sys.stderr)
    return 0

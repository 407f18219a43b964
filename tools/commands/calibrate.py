"""``navbank calibrate``: calibrate the anomaly detector on nominal runs to a target false-alarm rate.

The shipped thresholds come from the built-in calibration plans (``tools/campaigns/calibrations/``),
which fix every option below; this re-derives them and checks them on held-out runs::

    navbank calibrate --plan insight-approach --out-dir detectors --report calibration-insight-approach.json

A single calibration from options::

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
5. Held-out check (``--holdout M``): M more nominal runs on seeds disjoint from the calibration's
   (``RUNS_DIR/holdout``); each calibrated detector runs over their weight histories and its
   false-alarm count is set against the interval the calibration predicts for M fresh runs
   (:func:`tools.calibration.thresholds.holdout_check`). ``--report`` writes the calibrations
   and these checks as JSON.

Re-running the same command reuses the runs already in ``--runs-dir``; more ``--seeds`` adds
runs. Exit codes: 0 done, 1 no usable nominal run or the calibration failed, 2 a configuration
error, 130 interrupted (nothing written).
"""

from __future__ import annotations

import dataclasses
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from fsw.config import DetectorSection, GatingEntry
from fsw.fdir.config import config_to_yaml
from fsw.interface.yamlconfig import dump_yaml, load_text
from tools.calibration.plan import CalibrationPlan, builtin_names as plan_names, load_plan
from tools.calibration.record import CalibrationRecord, NetworkCalibration, write_record
from tools.calibration.thresholds import (CalibrationError, CalibrationReport, HoldoutCheck, calibrate,
                                          false_alarm_prediction_interval, holdout_check)
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
    # the procedure's options default to None: a --plan supplies them, and what the command line
    # gives explicitly wins over the plan (defaults in PROCEDURE_DEFAULTS)
    p.add_argument("--plan", metavar="NAME|FILE", default=None,
                   help="a calibration plan: built-in (" + ", ".join(plan_names()) + ") or a YAML file; it fixes the "
                        "scenario, networks, seeds, held-out runs and detector options below")
    p.add_argument("--scenario", default=None, metavar="S", help="built-in scenario or YAML file (default insight-approach)")
    p.add_argument("--network", action="append", default=None, metavar="NET",
                   help="gating network the detector watches (default chi2); repeat to calibrate several "
                        "networks on the same nominal runs (then --out-dir)")
    p.add_argument("--seeds", type=int, default=None, metavar="N", help="number of nominal runs (default 40)")
    p.add_argument("--base-seed", type=int, default=None, metavar="B", help="first seed (default 1001)")
    p.add_argument("--holdout", type=int, default=None, metavar="M",
                   help="then fly M more nominal runs on seeds disjoint from the calibration's and count each "
                        "calibrated detector's false alarms on them against the calibration's prediction interval "
                        "(default 0)")
    p.add_argument("--holdout-base-seed", type=int, default=None, metavar="B",
                   help="first held-out seed (default: right after the calibration seeds)")
    p.add_argument("--target-fa", type=float, default=None, help="false-alarm probability per run or segment (default 0.01)")
    p.add_argument("--warmup", type=int, default=None, metavar="B", help="batches ignored at the start of each run (default 0)")
    p.add_argument("--segment-batches", type=int, default=None, metavar="B",
                   help="false-alarm rate per segment of B batches instead of per run")
    p.add_argument("--persistence", type=int, nargs=2, default=None, metavar=("K", "N"),
                   help="declare when K of the last N batches exceed the threshold (default 3 5)")
    p.add_argument("--hold", type=int, default=None, help="batches below the clear threshold to clear (default 5)")
    p.add_argument("--statistic", choices=("mahalanobis", "max-z"), default=None, help="default mahalanobis")
    p.add_argument("--workers", type=int, default=None, metavar="N", help="parallel runs (default: cores)")
    p.add_argument("--executor", choices=("local", "dask"), default="local")
    p.add_argument("--scheduler", metavar="ADDR", default=None, help="dask scheduler address")
    p.add_argument("--runs-dir", metavar="DIR", default=None,
                   help="where the nominal runs go (default ./calibrate-SCENARIO-NETWORK; held-out runs in "
                        "DIR/holdout); reused on re-runs")
    p.add_argument("--out", metavar="FILE.yaml", default=None, help="detector configuration (default: stdout)")
    p.add_argument("--out-dir", metavar="DIR", default=None,
                   help="write DIR/detector-NETWORK.yaml for every --network (needed with several networks)")
    p.add_argument("--write-scenario", metavar="FILE", default=None,
                   help="also write the scenario with fsw.detector set to this calibration")
    p.add_argument("--report", metavar="FILE.json", default=None,
                   help="write the calibrations and hold-out checks as JSON (navbank validation-report reads it)")
    p.add_argument("--quiet", action="store_true", help="no progress line")


PROCEDURE_DEFAULTS = CalibrationPlan(scenario="insight-approach", networks=("chi2",), seeds=40, base_seed=1001,
                                     target_fa=0.01)
# command-line option -> plan field
PROCEDURE_OPTIONS = {"scenario": "scenario", "network": "networks", "seeds": "seeds", "base_seed": "base_seed",
                     "holdout": "holdout", "holdout_base_seed": "holdout_base_seed", "target_fa": "target_fa",
                     "warmup": "warmup", "segment_batches": "segment_batches", "persistence": "persistence",
                     "hold": "hold", "statistic": "statistic"}


def resolve_plan(args) -> CalibrationPlan:
    """The procedure: the plan (or the defaults), with every option the command line gave on top."""
    base = load_plan(args.plan) if args.plan else PROCEDURE_DEFAULTS
    given: dict[str, Any] = {}
    for opt, field in PROCEDURE_OPTIONS.items():
        value = getattr(args, opt)
        if value is not None:
            given[field] = tuple(dict.fromkeys(value)) if field == "networks" else (
                tuple(value) if field == "persistence" else value)
    if given.get("seeds", 1) < 1:
        raise UsageError("--seeds must be at least 1")
    if not 0.0 < given.get("target_fa", 0.5) < 1.0:
        raise UsageError("--target-fa must lie in (0, 1)")
    if given.get("holdout", 0) < 0:
        raise UsageError("--holdout must not be negative")
    try:
        return dataclasses.replace(base, **given)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


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


def reproduce_command(plan: CalibrationPlan, network: str) -> str:
    """The command line that recomputes this calibration (for the header of the written files)."""
    parts = ["navbank", "calibrate", "--scenario", plan.scenario, "--network", network,
             "--seeds", str(plan.seeds), "--base-seed", str(plan.base_seed), "--target-fa", f"{plan.target_fa:g}",
             "--warmup", str(plan.warmup), "--persistence", *map(str, plan.persistence), "--hold", str(plan.hold),
             "--statistic", plan.statistic]
    if plan.segment_batches is not None:
        parts += ["--segment-batches", str(plan.segment_batches)]
    return " ".join(shlex.quote(p) for p in parts)


def format_holdout(h: HoldoutCheck, runs: int) -> str:
    lvl = int(round(100 * h.level))
    verdict = "inside" if h.inside else "OUTSIDE"
    return (f"  held out         {h.false_alarms}/{h.units} = {h.rate:.4g} declared on {runs} fresh nominal runs "
            f"({lvl} % Clopper-Pearson [{h.ci[0]:.4g}, {h.ci[1]:.4g}]); predicted {h.predicted[0]} to "
            f"{h.predicted[1]}: {verdict}")


def run(args) -> int:
    if args.workers is not None and args.workers < 1:
        raise UsageError("--workers must be at least 1")
    plan = resolve_plan(args)
    networks = list(plan.networks)
    if len(networks) > 1 and (args.out or args.write_scenario):
        raise UsageError("with several --network use --out-dir (--out and --write-scenario take one network)")
    base = load_scenario(plan.scenario)
    nominal = expand(nominal_campaign(plan.scenario, networks, plan.seeds, plan.base_seed))
    held = plan.holdout_seeds()
    held_plan = expand(nominal_campaign(plan.scenario, networks, len(held), held.start)) if plan.holdout else None
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
    if args.report:
        check_output_file(args.report, "--report")
    check_output_dir(runs_dir, "--runs-dir")
    for todo, where in ((nominal, runs_dir), (held_plan, runs_dir / "holdout")):
        if todo is None:
            continue
        outcome = run_campaign(todo, where, executor_factory(args), quiet=args.quiet)
        if outcome.interrupted:
            print("navbank calibrate: interrupted; nothing written (run the same command again to resume)",
                  file=sys.stderr)
            return 130
    if args.out_dir:
        Path(args.out_dir).mkdir(parents=True, exist_ok=True)
    status = 0
    records = []
    for network in networks:
        code, record = _calibrate_one(args, plan, base, nominal, held_plan, runs_dir, network)
        status = max(status, code)
        if record is not None:
            records.append(record)
    if args.report and records:
        write_record(CalibrationRecord(plan=plan, generated=time.strftime("%Y-%m-%d", time.gmtime()),
                                       networks=tuple(records)), args.report)
    return status


def _calibrate_one(args, plan: CalibrationPlan, base: ScenarioConfig, nominal, held_plan, runs_dir: Path,
                   network: str) -> tuple[int, NetworkCalibration | None]:
    try:
        histories, filters, used = collect_histories(runs_dir, [t.id for t in nominal.tasks], network)
    except CalibrationError as exc:
        print(f"navbank calibrate: {exc}", file=sys.stderr)
        return 1, None
    failed = len(nominal.tasks) - len(used)
    if failed:
        print(f"navbank calibrate: {failed} nominal run(s) failed, missing or without {network} weights "
              f"(see {runs_dir}/runs.jsonl); "
              f"calibrating on {len(used)}", file=sys.stderr)
    if not histories:
        print(f"navbank calibrate: no successful nominal run to calibrate {network} on", file=sys.stderr)
        return 1, None
    try:
        detector, report = calibrate(
            histories, plan.target_fa, network=network, filters=filters, statistic=plan.statistic,
            persistence=plan.persistence, hold=plan.hold, warmup=plan.warmup,
            segment_batches=plan.segment_batches,
        )
    except CalibrationError as exc:
        print(f"navbank calibrate: calibration of {network} failed: {exc}", file=sys.stderr)
        return 1, None
    command = reproduce_command(plan, network)
    text = config_to_yaml(detector)
    out = args.out or (str(Path(args.out_dir) / f"detector-{network}.yaml") if args.out_dir else None)
    if out:
        Path(out).write_text(f"# reproduce: {command}\n" + text, encoding="utf-8")
    else:
        print(text, end="")
    if args.write_scenario:
        scen = calibrated_scenario(base, network, detector)
        seeds = plan.calibration_seeds()
        header = (f"# {scen.name} with the {network} detector calibrated on {len(used)} nominal runs "
                  f"(seeds {seeds.start}..{seeds.stop - 1}, target FA {plan.target_fa:g})\n")
        header += f"# reproduce: {command}\n"
        body = dump_yaml(scen, drop_defaults=True)
        load_text(ScenarioConfig, body, args.write_scenario)  # what we write must load back
        Path(args.write_scenario).write_text(header + body, encoding="utf-8")
    lines = [format_report(report, len(used), len(nominal.tasks))]
    check, held_used = None, 0
    if held_plan is not None:
        try:
            held, _, held_ids = collect_histories(runs_dir / "holdout", [t.id for t in held_plan.tasks], network)
            if held:
                check = holdout_check(detector, report, held, base.fsw.families())
                held_used = len(held_ids)
                lines.append(format_holdout(check, held_used))
            else:
                lines.append("  held out         no successful held-out run")
        except CalibrationError as exc:
            lines.append(f"  held out         not evaluated: {exc}")
    print("\n".join(lines), file=sys.stdout if out else sys.stderr)
    return 0, NetworkCalibration(network=network, runs=len(used), report=report, holdout=check,
                                 holdout_runs=held_used, command=command)

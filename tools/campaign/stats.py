"""Campaign statistics, recomputed from the rows of ``runs.jsonl`` (the latest row of each id).

Per cell (scenario x fault case x network variant):

* probability of detection P_D = k/n over the cell's successful runs with an injected fault, where
  k counts runs whose first declaration came at or after the true onset (a run that declared
  before the onset is a false alarm, not a detection, whatever happened later), with its
  Clopper–Pearson interval (exact binomial: the bounds are the Beta(k, n−k+1) and Beta(k+1, n−k)
  quantiles);
* false alarms on ``none`` cases: per run (runs with a declaration / runs, Clopper–Pearson), and
  per day: declarations / exposure, where a run is exposed from its start to its first declaration
  (or its end) — the maximum-likelihood rate of a Poisson process observed to its first event —
  with the exact Poisson interval (chi-square quantiles). Fault cases report their pre-onset false
  alarms per run;
* detection latency (declaration − true onset) over detected runs: median and 90th percentile
  (linear interpolation between order statistics, numpy's default);
* characterization: a confusion matrix of injected class vs diagnosed class (``none`` when
  nothing was declared) per scenario and variant, and the rate of correct classes among detections;
* mean weight of each filter per fault case for every gating network (Lubey & Ely 2022 Tables 3 and 4:
  rows = fault cases, columns = filters; the mean over seeds of each run's full-arc mean, and of
  its after-onset mean);
* position error: each filter's RMS error per run, summarised as mean / median / max over seeds;
* budget: the largest utilisation, overruns (total and runs with any), the largest final backlog;
* wall time per run.

Monitors: a variant with ``monitors`` evaluates several detectors on the same runs (the onboard one
and one replayed per monitored network, ``summary.monitors``). Each counts as its own detector
variant: the cell is split into one virtual cell per detector, labelled ``<variant> / <network>``
(``… (replayed)`` for a monitor on the onboard detector's own network), whose rows carry that
detector's anomaly block; every statistic above then comes out per network. The weights,
position errors and budget of the runs are those of the real cell (kept on the onboard-detector
cell only, so nothing is counted twice).

Cells whose detector is not calibrated (the scenario has no ``fsw.detector.calibration`` for
the detector network) cannot declare anything: their detection statistics are reported as n/a.
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections import defaultdict
from pathlib import Path
from typing import Iterable

import numpy as np
from scipy import stats as sps

from fsw.interface.messages import ANOMALY_CLASSES
from ground.report.intervals import clopper_pearson
from ground.report.row_types import DetectorFacts, ResultRow
from ground.report.summary_types import ErrorRecord
from tools.campaign.plan_file import PlanFile
from tools.campaign.stats_records import (Binomial, CampaignRuns, CampaignStats, CellBudget, CellDetector, CellRuns,
                                          CellStats, Confusion, FailedRun, FalseAlarms, Latency, NetworkWeights,
                                          PoissonRate, Spread, WeightTable, WeightTableRow)
from tools.campaign.store import PLAN, REPORT, RUNS, SUMMARY, read_rows, write_json_atomic, write_text_atomic

LEVEL = 0.95
NOMINAL = "none"
DAY_S = 86400.0


def binomial(k: int, n: int, level: float = LEVEL) -> Binomial:
    """k successes in n trials: rate and Clopper–Pearson interval (None when n = 0)."""
    if n == 0:
        return Binomial(k=0, n=0, rate=None, ci=None)
    return Binomial(k=int(k), n=int(n), rate=k / n, ci=clopper_pearson(k, n, level))


def poisson_rate(k: int, exposure: float, level: float = LEVEL) -> PoissonRate:
    """k events in ``exposure`` (days): rate and the exact (Garwood) Poisson interval."""
    if exposure <= 0.0:
        return PoissonRate(k=int(k), exposure_days=exposure, per_day=None, ci=None)
    a = 1.0 - level
    lo = 0.0 if k == 0 else float(sps.chi2.ppf(a / 2.0, 2 * k)) / 2.0 / exposure
    hi = float(sps.chi2.ppf(1.0 - a / 2.0, 2 * k + 2)) / 2.0 / exposure
    return PoissonRate(k=int(k), exposure_days=float(exposure), per_day=k / exposure, ci=(lo, hi))


def spread(values: Iterable[float | None], *, with_total: bool = False) -> Spread | None:
    v = np.array([x for x in values if x is not None and np.isfinite(x)], dtype=float)
    if v.size == 0:
        return None
    return Spread(n=int(v.size), mean=float(v.mean()), median=float(np.median(v)), max=float(v.max()),
                  min=float(v.min()), total=float(v.sum()) if with_total else None)


def latency_stats(latencies_s: Iterable[float]) -> Latency | None:
    """Median and 90th percentile of detection latencies, in hours."""
    h = np.array(list(latencies_s), dtype=float) / 3600.0
    if h.size == 0:
        return None
    p50, p90 = np.percentile(h, [50.0, 90.0])
    return Latency(n=int(h.size), median_h=float(p50), p90_h=float(p90), mean_h=float(h.mean()),
                   min_h=float(h.min()), max_h=float(h.max()))


def detector_label(variant: str, network: str, onboard: str | None) -> str:
    """Label of one detector of a variant with monitors (a monitor on the onboard network is
    marked, so the two never share a label)."""
    return f"{variant} / {network}" + (" (replayed)" if network == onboard and onboard is not None else "")


def monitored(detector: dict | None) -> list[str]:
    """The monitored networks of a cell's detector facts as plan.json writes them."""
    return list((detector or {}).get("monitors") or [])


def detector_rows(row: ResultRow) -> list[ResultRow]:
    """One row per detector of the run: the row itself when its variant has no monitors; else a
    row for the onboard detector and one per monitor, each with its own cell label, ``detector``
    and ``summary.anomaly``. A monitor that could not be evaluated makes a failed row."""
    nets = list(row.detector.monitors or ())
    if not nets:
        return [row]
    onboard = row.detector.network
    cell = row.cell
    out = [dataclasses.replace(row, cell=dataclasses.replace(cell, variant=detector_label(cell.variant, onboard, None)))]
    summary = row.summary if row.status == "ok" else None
    for net in nets:
        vrow = dataclasses.replace(row, cell=dataclasses.replace(cell, variant=detector_label(cell.variant, net, onboard)),
                                   detector=DetectorFacts(network=net, calibrated=True))
        if summary:
            mon = (summary.monitors or {}).get(net)
            if mon is None or mon.error is not None:
                err = mon.error if mon is not None else ErrorRecord(type="MissingMonitor",
                                                                    message=f"no monitor result for {net}")
                vrow = dataclasses.replace(vrow, status="failed", error=err, summary=None)
            else:
                assert mon.anomaly is not None  # a monitor block without an error holds its anomaly block
                vrow = dataclasses.replace(vrow, summary=dataclasses.replace(summary, anomaly=mon.anomaly))
        out.append(vrow)
    return out


def _cell_detector(info: dict, rows: list[ResultRow]) -> dict:
    if info.get("detector"):
        return info["detector"]
    return rows[0].detector.to_json() if rows else {}


def _expand_cells(cell_order: list[str], cell_info: dict[str, dict], rows_by_cell: dict[str, list[ResultRow]],
                  planned_by_cell: dict[str, int]) -> list[str]:
    """Split every cell whose variant has monitors into one virtual cell per detector (in place
    in the dictionaries; returns the new cell order)."""
    order: list[str] = []
    for key in cell_order:
        info = cell_info[key]
        rows = rows_by_cell.get(key, [])
        nets = monitored(info.get("detector")) or next((list(r.detector.monitors) for r in rows
                                                        if r.detector.monitors), [])
        if not nets:
            order.append(key)
            continue
        onboard = _cell_detector(info, rows).get("network")
        # the plan's detector facts or the rows' name the network (a cell with monitors has one or the other)
        assert isinstance(onboard, str)
        split: dict[str, list[ResultRow]] = defaultdict(list)
        for r in rows:
            for v in detector_rows(r):
                split[v.cell.key].append(v)
        variant = info.get("variant") or rows[0].cell.variant
        for net, is_monitor in [(onboard, False)] + [(n, True) for n in nets]:
            label = detector_label(variant, net, onboard if is_monitor else None)
            vkey = f"{info.get('scenario', rows[0].cell.scenario if rows else '')} / " \
                   f"{info.get('fault', rows[0].cell.fault if rows else '')} / {label}"
            cell_info[vkey] = {**info, "variant": label, "base_variant": variant, "monitor": is_monitor,
                               "detector": {**(info.get("detector") or {}), "network": net,
                                            "calibrated": True if is_monitor else
                                            (info.get("detector") or {}).get("calibrated", True)}}
            rows_by_cell[vkey] = split.get(vkey, [])
            if key in planned_by_cell:
                planned_by_cell[vkey] = planned_by_cell[key]
            order.append(vkey)
    return order


def _cell_stats(key: str, cell: dict, rows: list[ResultRow], planned: int | None, level: float) -> CellStats:
    ok = [r for r in rows if r.ok]
    failed = [r for r in rows if r.status != "ok"]
    # an ok row has its summary (ResultRow.ok): one per ok row, in their order
    summaries = [r.summary for r in ok if r.summary is not None]
    fault_class = rows[0].fault_class if rows else cell.get("fault_class", NOMINAL)
    if rows:
        detector = CellDetector(network=rows[0].detector.network, calibrated=rows[0].detector.calibrated)
    else:
        planned_det = cell.get("detector") or {}
        detector = CellDetector(network=planned_det.get("network"), calibrated=planned_det.get("calibrated"))
    base = CellStats(
        key=key, scenario=cell["scenario"], fault=cell["fault"], variant=cell["variant"],
        base_variant=cell.get("base_variant"), monitor=cell.get("monitor"), fault_class=fault_class,
        detector=detector,
        runs=CellRuns(planned=planned, ok=len(ok), failed=len(failed),
                      missing=None if planned is None else max(planned - len(ok) - len(failed), 0)),
        failed=tuple(FailedRun(id=r.id, seed=r.seed, type=r.error.type if r.error else None,
                               message=r.error.message if r.error else None) for r in failed),
        seeds=tuple(sorted(r.seed for r in ok)),
    )
    anomalies = [s.anomaly for s in summaries]
    note: str | None = None
    detection: Binomial | None = None
    false_alarm: FalseAlarms | None = None
    latency: Latency | None = None
    characterization: Binomial | None = None
    if not detector.can_declare:
        note = f"detector network {detector.network!r} not calibrated: no declarations possible"
    elif fault_class == NOMINAL:
        fa = [a for a in anomalies if a.declared and a.false_alarm]
        exposure = 0.0
        for r, a in zip(ok, anomalies):
            span = float(r.span_days or 0.0)
            exposure += min(float(a.time_day), span) if a.declared and a.time_day is not None else span
        false_alarm = FalseAlarms(per_run=binomial(len(fa), len(ok), level),
                                  per_day=poisson_rate(len(fa), exposure, level))
    else:
        fa = [a for a in anomalies if a.declared and a.false_alarm]
        det = [a for a in anomalies if a.detected]
        detection = binomial(len(det), len(ok), level)
        false_alarm = FalseAlarms(per_run=binomial(len(fa), len(ok), level), per_day=None,
                                  note="declarations before the injected onset")
        latency = latency_stats(a.latency_s for a in det if a.latency_s is not None)
        characterization = binomial(sum(bool(a.correct_class) for a in det), len(det), level)

    labels: set[str] = set()
    for s in summaries:
        labels.update(s.position_error_rms_km)
    order = summaries[0].filters if summaries else ()
    ordered = [f for f in order if f in labels] + sorted(labels - set(order))
    budgets = [s.budget for s in summaries]
    weights: dict[str, NetworkWeights] = {}
    nets: list[str] = []
    for s in summaries if not base.monitor else ():  # the runs' weights belong to the real cell
        nets += [n for n in s.gating if n not in nets]
    for net in nets:
        entries = [s.gating[net] for s in summaries if net in s.gating]
        filters = list(entries[0].mean_weights)
        means = {}
        for src, dst in (("mean_weights", "mean"), ("mean_weights_after_onset", "after_onset"),
                         ("final_weights", "final")):
            have = [getattr(e, src) for e in entries if getattr(e, src) is not None]
            if have:
                means[dst] = {f: float(np.mean([h[f] for h in have if f in h])) for f in filters}
        weights[net] = NetworkWeights(filters=tuple(filters), n=len(entries), **means)
    return dataclasses.replace(
        base, note=note, detection=detection, false_alarm=false_alarm, latency=latency,
        characterization=characterization,
        position_error_rms_km={lab: spread(s.position_error_rms_km.get(lab) for s in summaries) for lab in ordered},
        budget=CellBudget(
            max_utilisation=max((b.max_utilisation for b in budgets), default=None),
            overruns_total=int(sum(b.overruns for b in budgets)),
            runs_with_overruns=int(sum(1 for b in budgets if b.overruns > 0)),
            final_backlog_max=max((b.final_backlog for b in budgets), default=None),
            max_backlog=max((b.max_backlog for b in budgets), default=None),
        ),
        wall_time_s=spread((r.wall_time_s for r in rows if r.wall_time_s is not None), with_total=True),
        weights=weights,
    )


def _confusion(cells: list[CellStats], rows_by_cell: dict[str, list[ResultRow]]) -> list[Confusion]:
    groups: dict[tuple[str, str], tuple[str | None, dict[str, dict[str, int]]]] = {}
    for c in cells:
        if c.detection is None and c.false_alarm is None:
            continue  # uncalibrated detector
        _, counts = groups.setdefault((c.scenario, c.variant),
                                      (c.detector.network, defaultdict(lambda: defaultdict(int))))
        for r in rows_by_cell[c.key]:
            if not r.ok or r.summary is None:  # (an ok row has its summary)
                continue
            true = r.fault_class or r.summary.anomaly.true_class
            counts[true][r.summary.anomaly.diagnosed] += 1
    out = []
    for (scenario, variant), (detector, counts) in groups.items():
        seen_true = set(counts)
        seen_diag = {d for row in counts.values() for d in row}
        classes = [c for c in ANOMALY_CLASSES if c in seen_true | seen_diag]
        classes += sorted((seen_true | seen_diag) - set(classes))
        true_classes = [c for c in classes if c in seen_true]
        out.append(Confusion(scenario=scenario, variant=variant, detector=detector,
                             true_classes=tuple(true_classes), diagnosed_classes=tuple(classes),
                             matrix={t: {d: int(counts[t].get(d, 0)) for d in classes} for t in true_classes}))
    return out


def _weight_tables(cells: list[CellStats]) -> list[WeightTable]:
    filters: dict[tuple[str, str, str], list[str]] = {}
    rows: dict[tuple[str, str, str], list[WeightTableRow]] = {}
    for c in cells:
        variant = c.base_variant if c.base_variant is not None else c.variant
        for net, w in c.weights.items():
            key = (c.scenario, variant, net)
            names = filters.setdefault(key, list(w.filters))
            names += [f for f in w.filters if f not in names]
            rows.setdefault(key, []).append(WeightTableRow(case=c.fault, n=w.n, mean=w.mean,
                                                           after_onset=w.after_onset))
    return [WeightTable(scenario=s, variant=v, network=n, filters=tuple(filters[(s, v, n)]), rows=tuple(rows[(s, v, n)]))
            for (s, v, n) in filters]


def compute(rows: list[ResultRow], plan: PlanFile | None = None, *, level: float = LEVEL, bad_lines: int = 0,
            torn_tail: bool = False) -> CampaignStats:
    """Statistics of a campaign from its rows (all of them; the latest per id counts) and its
    plan (``plan.json``)."""
    latest: dict[str, ResultRow] = {}
    for r in rows:
        latest[r.id] = r
    planned_by_cell: dict[str, int] = defaultdict(int)
    cell_order: list[str] = []
    cell_info: dict[str, dict] = {}
    plan_ids: set[str] | None = None
    if plan is not None:
        plan_ids = {r.id for r in plan.runs}
        for c in plan.cells:
            cell_order.append(c.key)
            facts = c.to_json()
            cell_info[c.key] = {k: facts[k] for k in ("scenario", "fault", "variant", "fault_class") if k in facts}
            cell_info[c.key]["detector"] = c.detector.to_json() if c.detector is not None else {}
        for run in plan.runs:
            planned_by_cell[run.cell] += 1
    rows_by_cell: dict[str, list[ResultRow]] = defaultdict(list)
    for r in latest.values():
        if plan_ids is not None and r.id not in plan_ids:
            continue  # a row of an earlier version of the campaign (its cell was edited)
        key = r.cell.key
        rows_by_cell[key].append(r)
        if key not in cell_info:
            cell_order.append(key)
            cell_info[key] = r.cell.to_json()
    counted = [r for rs in rows_by_cell.values() for r in rs]
    cell_order = _expand_cells(cell_order, cell_info, rows_by_cell, planned_by_cell)
    cells = [_cell_stats(k, dict(cell_info[k]), sorted(rows_by_cell.get(k, []), key=lambda r: r.seed),
                         planned_by_cell.get(k) if plan is not None else None, level) for k in cell_order]
    return CampaignStats(
        campaign=(plan.name if plan is not None else None) or (counted[0].campaign if counted else None),
        description=plan.description if plan is not None else "",
        generated_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        confidence_level=level,
        runs=CampaignRuns(
            planned=len(plan_ids) if plan_ids is not None else None,
            ok=sum(1 for r in counted if r.status == "ok"),
            failed=sum(1 for r in counted if r.status != "ok"),
            missing=None if plan_ids is None else len(plan_ids - {r.id for r in counted}),
            stale_rows=len(latest) - len(counted),
            unreadable_lines=bad_lines, torn_tail=torn_tail,
            wall_time_s_total=float(sum(r.wall_time_s or 0.0 for r in counted)),
        ),
        cells=tuple(cells),
        confusion=tuple(_confusion(cells, rows_by_cell)),
        weight_tables=tuple(_weight_tables(cells)),
    )


def compute_directory(directory: str | Path, level: float = LEVEL) -> CampaignStats:
    """Statistics of the campaign in ``directory`` (its runs.jsonl and, if present, plan.json)."""
    d = Path(directory)
    if not (d / RUNS).exists():
        raise FileNotFoundError(f"{d / RUNS}: no such file (not a campaign directory?)")
    read = read_rows(d / RUNS)
    plan = PlanFile.from_json(json.loads((d / PLAN).read_text())) if (d / PLAN).exists() else None
    return compute(read.rows, plan, level=level, bad_lines=read.bad_lines, torn_tail=read.torn_tail)


def write_outputs(directory: str | Path, summary: CampaignStats) -> tuple[Path, Path]:
    """Write ``summary.json`` and ``report.md`` into the campaign directory."""
    from tools.campaign.report import render

    d = Path(directory)
    write_json_atomic(d / SUMMARY, summary.to_json())
    write_text_atomic(d / REPORT, render(summary))
    return d / SUMMARY, d / REPORT

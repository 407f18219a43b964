"""The summary of one run, computed from its messages (in memory, or read back from MCAP).

``summarize`` is the single definition of every number ``navbank run`` prints and writes to
``summary.json``; campaigns aggregate these records. It lives on the ground because it is pure
post-processing of telemetry: the report reads what it computes, and the tools only call it. Position errors compare each Estimate
with the Truth of the same epoch (the FSW publishes estimates on a grid that the simulator's
truth cadence contains), so no interpolation enters the score.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any, Iterable

import numpy as np

from fsw.core.counters import stage_cpu_by_label
from fsw.interface import messages as m, topics
from ground.report.nav_data import bplane_final, bplane_traces, nis_statistics, residual_traces
from ground.report.run_facts import anomaly_summary
from ground.report.summary_types import (BPlaneEntry, NisEntry, BudgetBlock, CommandEntry, FaultBlock, FaultEventRecord, GatingEntry,
                                         MeasurementCounts, RunSummary)

DAY_S = 86400.0

#: MCAP topic prefixes of the channels the ground adds for Foxglove: not ICD messages, nothing to summarise.
FOXGLOVE_PREFIXES = ("/foxglove/", "/plot/")
#: ICD channels a run's summary leaves out: the measurements (the simulator's end-of-run status
#: counts them) and the residuals (decoding them strictly costs seconds; their NIS statistics are
#: the report's, ``navbank report``, and the campaigns', from in-process summaries).
UNREAD_TOPICS = ("/sim/measurements", "/fsw/residuals")


def reads_topic(mcap_topic: str) -> bool:
    """Whether the summary of a recorded run reads the channel ``mcap_topic`` (e.g. ``/fsw/status``)."""
    return mcap_topic not in UNREAD_TOPICS and not mcap_topic.startswith(FOXGLOVE_PREFIXES)


def _by_topic(messages: Iterable[tuple[str, Any]]) -> dict[str, list]:
    out: dict[str, list] = defaultdict(list)
    for topic, msg in messages:
        out[topic.strip("/")].append(msg)
    return out


def _command_entry(c: m.CommandRecord, t0: float) -> CommandEntry:
    tc = c.telecommand
    return CommandEntry(t_s=c.t_s, day=(c.t_s - t0) / DAY_S, id=c.reply.id, command=tc.command if tc else "malformed",
                        ok=c.reply.ok, error=c.reply.error, network=tc.network if tc else None,
                        filter=tc.filter if tc else None, param=tc.param if tc else None,
                        value=tc.value if tc else None)


def _stage_cpu_us(counts: dict[str, int]) -> dict[str, float] | None:
    """CPU µs per processed measurement of each stage label (budget mode cpu), largest first."""
    by_label = stage_cpu_by_label(counts)
    processed = counts.get("processed", 0)
    if not by_label or processed <= 0:
        return None
    return {label: cpu / processed * 1e6 for label, cpu in sorted(by_label.items(), key=lambda kv: -kv[1])}


def summarize(messages: Iterable[tuple[str, Any]], *, scenario: str, seed: int, fault: str | None,
              t0: float, wall_time_s: float | None = None, lost: int | None = None) -> RunSummary:
    """Summary of a run (see the module docstring). ``t0`` is the scenario start epoch."""
    by = _by_topic(messages)
    meas = by.get(topics.SIM_MEASUREMENTS, [])
    sim_status = [s for s in by.get(topics.SIM_STATUS, []) if s.state == "end-of-run"]
    fsw_status = by.get(topics.FSW_STATUS, [])
    fsw_end = next((s for s in reversed(fsw_status) if s.state == "end-of-run"), None)
    fsw_last = fsw_status[-1] if fsw_status else None
    fsw_final = fsw_end or fsw_last
    counts = fsw_final.counts if fsw_final else {}
    published = sim_status[-1].counts.get("measurements", len(meas)) if sim_status else len(meas)

    events = sorted(by.get(topics.SIM_FAULTS, []), key=lambda e: e.t_s)
    starts = [e for e in events if e.event == "start"]
    onset_true = starts[0].t_s if starts else None
    true_class = starts[0].fault_class if starts else "none"

    weights: dict[str, GatingEntry] = {}
    for topic, msgs in by.items():
        if not topic.startswith(topics.FSW_WEIGHTS + "/") or not msgs:
            continue
        w = np.array([x.weights for x in msgs], dtype=float)
        names = msgs[-1].filters

        def mean(sel: np.ndarray) -> dict[str, float]:
            return {n: float(v) for n, v in zip(names, w[sel].mean(axis=0))}

        before = np.array([onset_true is not None and x.t_s < onset_true for x in msgs])
        weights[msgs[-1].network] = GatingEntry(
            mean_weights={n: float(v) for n, v in zip(names, w.mean(axis=0))},
            updates=len(msgs),
            mean_weights_before_onset=mean(before) if before.any() else None,
            mean_weights_after_onset=mean(~before) if onset_true is not None and (~before).any() else None,
            final_weights={n: float(v) for n, v in zip(names, w[-1])})

    anomaly = anomaly_summary(by.get(topics.FSW_ANOMALY, []), onset_true=onset_true, true_class=true_class, t0=t0)

    truth = {round(t.t_s, 3): np.array(t.position_km) for t in by.get(topics.SIM_TRUTH, [])}
    pos_rms: dict[str, float] = {}
    pos_final: dict[str, float] = {}
    within_3sigma: dict[str, float] = {}
    filters: list[str] = []
    for topic, msgs in by.items():
        if not topic.startswith(topics.FSW_ESTIMATE + "/"):
            continue
        label = topic.split("/", 2)[2]
        err, sig = [], []
        for e in msgs:
            tr = truth.get(round(e.t_s, 3))
            if tr is not None:
                err.append(float(np.linalg.norm(np.array(e.position_km) - tr)))
                sig.append(e.position_sigma_km)
        if err:
            e_arr, s_arr = np.array(err), np.array(sig)
            pos_rms[label] = float(math.sqrt(np.mean(e_arr**2)))
            pos_final[label] = float(e_arr[-1])
            within_3sigma[label] = float(np.mean(e_arr <= 3.0 * s_arr))
        if label not in ("combined", "best"):
            filters.append(label)

    budget_msgs = by.get(topics.FSW_BUDGET, [])
    budget = BudgetBlock(
        frames=(budget_msgs[-1].frame + 1) if budget_msgs else 0,
        reports=len(budget_msgs),
        overruns=max((b.overruns for b in budget_msgs), default=0),
        max_utilisation=max((b.utilisation for b in budget_msgs), default=0.0),
        mean_utilisation_busy=float(np.mean([b.utilisation for b in budget_msgs if b.processed])) if any(b.processed for b in budget_msgs) else 0.0,
        max_backlog=max((b.backlog for b in budget_msgs), default=0),
        final_backlog=budget_msgs[-1].backlog if budget_msgs else 0,
        errors=max((b.errors for b in budget_msgs), default=0),
        mode=budget_msgs[-1].mode if budget_msgs else None,
        stage_cpu_us=_stage_cpu_us(counts),
    )

    lost_count = counts.get("lost", 0) if lost is None else lost
    # a command refused for its authentication was never looked at: it is counted, not listed
    served = [_command_entry(c, t0) for c in by.get(topics.FSW_COMMANDS, []) if not c.refused]
    refused = ({"telecommands": int(counts["refused_commands"]), "statuses": int(counts.get("refused_statuses", 0))}
               if "refused_commands" in counts else None)
    return RunSummary(
        scenario=scenario,
        seed=seed,
        t0=t0,
        fault=FaultBlock(preset=fault, fault_class=true_class, events=tuple(
            FaultEventRecord(id=e.fault_id, type=e.fault_type, event=e.event, t_s=e.t_s,
                             day=(e.t_s - t0) / DAY_S, magnitude=e.magnitude) for e in events)),
        measurements=MeasurementCounts(
            published=int(published),
            processed=int(counts.get("processed", 0)),
            rejected=int(counts.get("rejected", 0)),
            lost=int(lost_count),
            duplicates=int(counts.get("duplicates", 0)),
            reordered=int(counts.get("reordered", 0)),
            unprocessed=None if "unprocessed" not in counts else int(counts["unprocessed"]),
        ),
        filters=tuple(sorted(filters, key=lambda f: filters.index(f))),
        gating=weights,
        anomaly=anomaly,
        position_error_rms_km=pos_rms,
        position_error_final_km=pos_final,
        position_within_3sigma=within_3sigma,
        budget=budget,
        wall_time_s=wall_time_s,
        commands=tuple(served) or None,
        refused=refused,
        bplane=_bplane_entries(by) or None,
        nis=_nis_entries(by) or None,
    )


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None


def _bplane_entries(by: dict[str, list]) -> dict[str, BPlaneEntry]:
    planes = {t.split("/", 2)[2]: [x for x in msgs if isinstance(x, m.BPlane)] for t, msgs in by.items()
              if t.startswith(topics.FSW_BPLANE + "/")}
    if not planes:
        return {}
    truth = [x for x in by.get(topics.SIM_TRUTH, []) if isinstance(x, m.Truth)]
    final = bplane_final(bplane_traces(planes, truth))
    return {label: BPlaneEntry(
        t_s=f["t_s"], b_dot_r_km=f["b_dot_r_km"], b_dot_t_km=f["b_dot_t_km"], b_dot_r_sigma_km=f["b_dot_r_sigma_km"],
        b_dot_t_sigma_km=f["b_dot_t_sigma_km"], b_dot_r_error_km=_finite(f["b_dot_r_error_km"]),
        b_dot_t_error_km=_finite(f["b_dot_t_error_km"]), periapsis_error_s=_finite(f["periapsis_error_s"]),
        periapsis_sigma_s=f["periapsis_sigma_s"]) for label, f in final.items()}


def _nis_entries(by: dict[str, list]) -> dict[str, dict[str, NisEntry]]:
    stats = nis_statistics(residual_traces([x for x in by.get(topics.FSW_RESIDUALS, []) if isinstance(x, m.Residuals)]))
    return {kind: {name: NisEntry(count=int(v["count"]), dimension=int(v["dimension"]), mean_nis=v["mean_nis"],
                                  outside_95=v["outside_95"]) for name, v in per.items()}
            for kind, per in stats.items()}

"""The headline facts of a run, computed from its messages when no ``summary.json`` is at hand.

The dictionary has the keys and meaning of the run summary that ``navbank run`` writes (fault,
measurements, filters, gating, anomaly, position_error_*, budget), so the Markdown report renders
either one. Only what the messages themselves carry is filled in: scenario and seed are None.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Sequence

import numpy as np

from fsw.interface import messages as m
from ground.report.run_data import DAY_S, RunData, declared_epoch
from ground.report.summary_types import AnomalyBlock


def _weights(data: RunData) -> dict[str, dict[str, Any]]:
    onset = data.onset_s
    out: dict[str, dict[str, Any]] = {}
    for net, tr in data.weights.items():
        if not len(tr.t_s):
            continue
        names = tr.filters

        def mean(sel: np.ndarray) -> dict[str, float]:
            return {n: float(v) for n, v in zip(names, np.nanmean(tr.weights[sel], axis=0))}

        entry: dict[str, Any] = {"mean_weights": mean(np.ones(len(tr.t_s), dtype=bool)), "updates": int(len(tr.t_s))}
        if onset is not None:
            before = tr.t_s < onset
            if before.any():
                entry["mean_weights_before_onset"] = mean(before)
            if (~before).any():
                entry["mean_weights_after_onset"] = mean(~before)
        entry["final_weights"] = {n: float(v) for n, v in zip(names, tr.weights[-1])}
        out[net] = entry
    return out


def anomaly_summary(reports: Sequence[m.AnomalyReport], *, onset_true: float | None, true_class: str,
                    t0: float) -> AnomalyBlock:
    """The ``anomaly`` block of a summary from a detector's reports, in time order.

    ``reports`` are the AnomalyReport messages of the onboard detector, or those of a detector
    replayed on the ground through the same reporter (``summary["monitors"]``,
    :func:`tools.campaign.worker.replay_detector`). The first
    flagged report gives the declaration epoch and the onset estimate; the class is the one the
    detector settled on (the last flagged report: it refines as evidence grows). A declaration
    before the true onset (or with none injected) is a false alarm, otherwise its latency is
    declaration − true onset.
    """
    first = next((r for r in reports if r.flag), None)
    block = AnomalyBlock(
        detector=bool(reports), declared=first is not None,
        time=None, time_day=None, onset_true=onset_true,
        onset_true_day=None if onset_true is None else (onset_true - t0) / DAY_S,
        onset_estimate=None, latency_s=None, anomaly_class="none", true_class=true_class,
        confidence=0.0, network=reports[-1].network if reports else None,
        false_alarm=False, correct_class=None, final_flag=bool(reports[-1].flag) if reports else False,
        final_class=reports[-1].anomaly_class if reports else "none",
    )
    if first is None:
        return block
    t_decl = declared_epoch(first)
    last_flagged = [r for r in reports if r.flag][-1]
    false_alarm = onset_true is None or t_decl < onset_true
    latency_s = None if onset_true is None or false_alarm else t_decl - onset_true
    return dataclasses.replace(
        block, time=t_decl, time_day=(t_decl - t0) / DAY_S, onset_estimate=first.onset_s,
        anomaly_class=last_flagged.anomaly_class, first_class=first.anomaly_class,
        confidence=float(last_flagged.confidence), network=first.network, false_alarm=false_alarm,
        latency_s=latency_s,
        latency_day=None if latency_s is None else latency_s / DAY_S,
        correct_class=last_flagged.anomaly_class == true_class)


def _anomaly(data: RunData) -> AnomalyBlock:
    starts = data.fault_starts
    true_class = min(starts, key=lambda e: e.t_s).fault_class if starts else "none"
    reports = list(data.anomaly.reports) if data.anomaly is not None else []
    return anomaly_summary(reports, onset_true=data.onset_s, true_class=true_class, t0=data.t0)


def _budget(data: RunData) -> dict[str, Any]:
    b = data.budget
    if b is None or not len(b.t_s):
        return {}
    busy = b.processed > 0
    return {
        "reports": int(len(b.t_s)), "mode": b.mode, "overruns": int(b.overruns), "errors": int(b.errors),
        "max_utilisation": float(b.utilisation.max()),
        "mean_utilisation_busy": float(b.utilisation[busy].mean()) if busy.any() else 0.0,
        "max_backlog": int(b.backlog.max()), "final_backlog": int(b.backlog[-1]),
    }


def run_facts(data: RunData) -> dict[str, Any]:
    """Summary-shaped facts of a run (see the module docstring)."""
    pos_rms, pos_final, within = {}, {}, {}
    for label, tr in data.position.items():
        if len(tr.error):
            pos_rms[label] = float(math.sqrt(np.mean(tr.error**2)))
            pos_final[label] = float(tr.error[-1])
            within[label] = float(np.mean(tr.error <= 3.0 * tr.sigma))
    fsw = data.status.get("fsw")
    counts = fsw.counts if fsw is not None else {}
    published = sum(len(t) for t, _ in data.measurements.values())
    return {
        "scenario": None,
        "seed": None,
        "run_id": data.run_id,
        "fault": {"preset": None, "class": _anomaly(data).true_class,
                  "events": [{"id": e.fault_id, "type": e.fault_type, "event": e.event, "t_s": e.t_s,
                              "day": (e.t_s - data.t0) / DAY_S, "magnitude": dict(e.magnitude)} for e in data.faults]},
        "measurements": {"published": published, "processed": int(counts.get("processed", 0)),
                         "rejected": int(counts.get("rejected", 0)), "lost": int(counts.get("lost", 0)),
                         "by_kind": {k: len(t) for k, (t, _) in data.measurements.items()}},
        "filters": list(data.filters),
        "gating": _weights(data),
        "anomaly": _anomaly(data).to_json(),
        "position_error_rms_km": pos_rms,
        "position_error_final_km": pos_final,
        "position_within_3sigma": within,
        "budget": _budget(data),
    }

"""What a campaign worker does with one run: fly it in process and return one result row.

The function is importable by name (``tools.campaign.worker.execute``) so a spawned process pool
and a dask worker run the same code. Its input and output are plain data: the row (the run's
summary, id, cell, seed, status, error, wall time) and, on request, gating networks' weight
histories as compact arrays — never the run's messages, which are ~10^5 objects for a 45-day run.

Monitors (``payload["monitors"]``: network -> detector calibration) are further anomaly
detectors evaluated on the same run: each network's FilterWeights stream is replayed, in order,
through a fresh :class:`~fsw.fdir.detector.AnomalyDetector` built exactly as the FSW builds its own
(the calibration and the bank's family tags), and ``summary["monitors"][network]`` gets the same
block as ``summary["anomaly"]`` (one definition: :func:`ground.report.run_facts.anomaly_summary`).

Any exception raised by the run itself is caught here and becomes a ``failed`` row with the error
type, message and the tail of the traceback: one bad run never stops a campaign.
"""

from __future__ import annotations

import os
import socket
import time
import traceback
from typing import Any, Sequence

import numpy as np

from fsw.fdir.config import DetectorConfig
from fsw.core.telemetry import AnomalyReporter
from fsw.fdir.detector import AnomalyDetector
from fsw.fdir.errors import FdirInputError
from fsw.fdir.families import FilterFamily
from fsw.interface import messages as m, topics, typed
from tools.inprocess import RunResult, run_in_process
from tools.scenario import ScenarioConfig
from ground.report.run_facts import anomaly_summary

TRACEBACK_LINES = 12


def weight_history(result: RunResult, network: str) -> dict[str, Any]:
    """The FilterWeights history of ``network``: filter names, epochs, batch indices, weights,
    per-filter statistics and (hierarchical networks) the top-level weight of each bank."""
    msgs = result.topic(f"{topics.FSW_WEIGHTS}/{network}")
    if not msgs:
        return {"filters": [], "t_s": np.zeros(0), "batch": np.zeros(0, dtype=np.int64),
                "weights": np.zeros((0, 0)), "statistic": np.zeros((0, 0)), "group_names": [],
                "groups": np.zeros((0, 0))}
    group_names = list(msgs[-1].groups)
    stat_len = len(msgs[-1].statistic)
    return {
        "filters": list(msgs[-1].filters),
        "t_s": np.array([m.t_s for m in msgs], dtype=float),
        "batch": np.array([m.batch for m in msgs], dtype=np.int64),
        "weights": np.array([m.weights for m in msgs], dtype=float),
        "statistic": np.array([m.statistic if len(m.statistic) == stat_len else (np.nan,) * stat_len
                               for m in msgs], dtype=float),
        "group_names": group_names,
        "groups": np.array([[m.groups.get(g, np.nan) for g in group_names] for m in msgs], dtype=float),
    }


def replay_detector(messages: Sequence[tuple[str, object]], calibration: DetectorConfig,
                    families: Sequence[FilterFamily], t_start: float) -> list[m.AnomalyReport]:
    """The reports a detector on ``calibration.network`` would have given had it run onboard.

    ``messages`` are the run's ``(topic, message)`` pairs in emission order. The network's
    FilterWeights go, in order, through a fresh detector wrapped in the FSW's own
    :class:`~fsw.core.telemetry.AnomalyReporter` (all filters active, as in campaign runs), so the
    states, the dating of a declaration and the ``AnomalyReport`` messages are the onboard ones.
    The reporter needs to know the frame each batch was made in: onboard, a busy frame's
    BudgetReport is emitted right after the frame, so it is the next one after the weights;
    weights with no BudgetReport after them were made outside the frames (end of run). The
    first report is the detector's state before any batch, dated ``t_start``; then one per batch.
    """
    reporter = AnomalyReporter(AnomalyDetector(calibration, families))
    w_topic = f"{topics.FSW_WEIGHTS}/{calibration.network}"
    batches: list[m.FilterWeights] = []
    frame_end: list[float | None] = []
    pending: list[int] = []
    for topic, msg in messages:
        topic = topic.strip("/")
        if topic == w_topic and isinstance(msg, m.FilterWeights):
            batches.append(msg)
            frame_end.append(None)
            pending.append(len(batches) - 1)
        elif topic == topics.FSW_BUDGET and isinstance(msg, m.BudgetReport):
            for i in pending:
                frame_end[i] = msg.t_s
            pending.clear()
    reports = [reporter.report(reporter.state, t_start)]
    for msg, t_frame in zip(batches, frame_end):
        reports.append(reporter.report(reporter.consume_weights(msg, t_frame), msg.t_s))
    return reports


def monitor_summaries(result: RunResult, monitors: dict[str, dict]) -> dict[str, dict]:
    """``summary["monitors"]``: the anomaly block of every monitored network of the run. A
    detector that rejects the run's weights (another bank, bad values) gives ``{"error": ...}``
    for that network instead of ending the run."""
    a = result.summary["anomaly"]
    families = result.config.fsw.families()
    t0 = float(result.summary["t0"])
    out: dict[str, dict] = {}
    for net, cal_data in monitors.items():
        try:
            cal = typed.decode(DetectorConfig, cal_data)
            reports = replay_detector(result.messages, cal, families, t0)
        except (FdirInputError, ValueError, typed.DecodeError) as exc:
            out[net] = {"error": error_record(exc)}
            continue
        out[net] = anomaly_summary(reports, onset_true=a["onset_true"], true_class=a["true_class"], t0=t0)
    return out


def error_record(exc: BaseException) -> dict[str, str]:
    tb = traceback.format_exception(type(exc), exc, exc.__traceback__)
    tail = "".join(tb).rstrip().splitlines()[-TRACEBACK_LINES:]
    return {"type": type(exc).__name__, "message": str(exc), "traceback": "\n".join(tail)}


def base_row(payload: dict) -> dict[str, Any]:
    return {
        "id": payload["id"], "cell": payload["cell"], "seed": payload["seed"],
        "fault_class": payload["fault_class"], "detector": payload["detector"],
        "span_days": payload["span_days"],
    }


def execute(payload: dict) -> dict[str, Any]:
    """Run one campaign run; returns ``{"row": row, "weights": None | {network: arrays}}``."""
    t0 = time.perf_counter()
    row = base_row(payload)
    row.update({"host": socket.gethostname(), "pid": os.getpid()})
    weights = None
    try:
        cfg = typed.decode(ScenarioConfig, payload["scenario"])
        result = run_in_process(cfg, payload["seed"], fault_label=payload["fault_label"], run_id=payload["id"])
        nets = payload.get("extract_weights") or ()
        if nets:
            weights = {net: weight_history(result, net) for net in nets}
        if payload.get("monitors"):
            result.summary["monitors"] = monitor_summaries(result, payload["monitors"])
        row.update({"status": "ok", "error": None, "summary": result.summary})
        del result
    except Exception as exc:  # a failed run is data for the campaign, not the end of it
        row.update({"status": "failed", "error": error_record(exc), "summary": None})
    row["wall_time_s"] = time.perf_counter() - t0
    row["finished_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    return {"row": row, "weights": weights}

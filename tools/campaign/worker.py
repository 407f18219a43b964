"""What a campaign worker does with one run: fly it in process and return one result row.

The function is importable by name (``tools.campaign.worker.execute``) so a spawned process pool
and a dask worker run the same code. Its input and output are declared records: a
:class:`~tools.campaign.task.RunTask` in, a :class:`RunOutcome` out — the
:class:`~ground.report.row_types.ResultRow` (the run's summary, id, cell, seed, status, error, wall
time) and, on request, gating networks' weight histories as compact arrays — never the run's
messages, which are ~10^5 objects for a 45-day run.

Monitors (``task.monitors``: network -> detector calibration) are further anomaly
detectors evaluated on the same run: each network's FilterWeights stream is replayed, in order,
through a fresh :class:`~fsw.fdir.detector.AnomalyDetector` built exactly as the FSW builds its own
(the calibration and the bank's family tags), and ``summary.monitors[network]`` gets the same
block as ``summary.anomaly`` (one definition: :func:`ground.report.run_facts.anomaly_summary`).

Any exception raised by the run itself is caught here and becomes a ``failed`` row with the error
type, message and the tail of the traceback: one bad run never stops a campaign.
"""

from __future__ import annotations

import dataclasses
import os
import socket
import time
import traceback
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from fsw.fdir.config import DetectorConfig
from fsw.fdir.detector import AnomalyDetector, AnomalyState
from fsw.fdir.errors import FdirInputError
from fsw.fdir.families import FilterFamily
from fsw.interface import messages as m, topics, typed
from ground.report.row_types import ResultRow
from ground.report.run_facts import anomaly_summary
from ground.report.run_weights import RunWeights
from ground.report.summary_types import AnomalyBlock, ErrorRecord, MonitorBlock
from tools.campaign.task import RunTask
from tools.inprocess import RunResult, run_in_process
from tools.scenario import ScenarioConfig

TRACEBACK_LINES = 12


def weight_history(result: RunResult, network: str) -> RunWeights:
    """The FilterWeights history of ``network`` in the run."""
    msgs = result.topic(f"{topics.FSW_WEIGHTS}/{network}")
    if not msgs:
        return RunWeights.empty()
    group_names = tuple(msgs[-1].groups)
    stat_len = len(msgs[-1].statistic)
    return RunWeights(
        filters=tuple(msgs[-1].filters),
        t_s=np.array([m.t_s for m in msgs], dtype=float),
        batch=np.array([m.batch for m in msgs], dtype=np.int64),
        weights=np.array([m.weights for m in msgs], dtype=float),
        statistic=np.array([m.statistic if len(m.statistic) == stat_len else (np.nan,) * stat_len
                            for m in msgs], dtype=float),
        group_names=group_names,
        groups=np.array([[m.groups.get(g, np.nan) for g in group_names] for m in msgs], dtype=float),
    )


@dataclass(frozen=True)
class ReplayedReport:
    """A replayed detector's verdict after one batch, with the attributes of an AnomalyReport
    that :func:`ground.report.run_facts.anomaly_summary` reads."""

    t_s: float
    flag: bool
    anomaly_class: str
    confidence: float
    onset_s: float | None
    declared_s: float | None
    network: str


def replay_detector(messages: Sequence[tuple[str, Any]], calibration: DetectorConfig,
                    families: Sequence[FilterFamily], t_start: float) -> list[ReplayedReport]:
    """The verdicts of a detector on ``calibration.network`` had it run onboard in this run.

    ``messages`` are the run's ``(topic, message)`` pairs in emission order. The detector sees
    every FilterWeights of its network (all filters active, as in campaign runs). Onboard, a
    declaration is known at the end of the frame whose gating stage made it (``fsw.core``: the
    executive's clock), and that frame's BudgetReport is the next one emitted after the weights;
    the replay dates each declaration the same way (the last frame end when none follows)."""
    det = AnomalyDetector(calibration, families)
    w_topic = f"{topics.FSW_WEIGHTS}/{calibration.network}"
    states: list[AnomalyState] = []
    frame_end: list[float | None] = []
    pending: list[int] = []
    last_frame_end = t_start
    for topic, msg in messages:
        topic = topic.strip("/")
        if topic == w_topic:
            states.append(det.update(msg.t_s, msg.weights, msg.filters,
                                     batch_statistic=msg.statistic if msg.statistic else None))
            frame_end.append(None)
            pending.append(len(states) - 1)
        elif topic == topics.FSW_BUDGET and isinstance(msg, m.BudgetReport):
            last_frame_end = msg.t_s
            for i in pending:
                frame_end[i] = msg.t_s
            pending.clear()
    for i in pending:
        frame_end[i] = last_frame_end
    initial = ReplayedReport(t_start, False, "none", 0.0, None, None, calibration.network)
    out = [initial]
    was_flagged = False
    declared_at = 0.0
    for st, t_frame in zip(states, frame_end):
        if st.flag and not was_flagged:
            declared_at = max(float(st.declared_t if st.declared_t is not None else st.t), t_frame or 0.0)
        was_flagged = st.flag
        out.append(ReplayedReport(
            t_s=float(st.t), flag=bool(st.flag), anomaly_class=st.anomaly_class,
            confidence=float(min(max(st.confidence, 0.0), 1.0)),
            onset_s=None if st.onset_t is None else float(st.onset_t),
            declared_s=None if st.declared_t is None else max(float(st.declared_t), declared_at),
            network=calibration.network))
    return out


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


def error_record(exc: BaseException) -> ErrorRecord:
    tb = traceback.format_exception(type(exc), exc, exc.__traceback__)
    tail = "".join(tb).rstrip().splitlines()[-TRACEBACK_LINES:]
    return ErrorRecord(type=type(exc).__name__, message=str(exc), traceback="\n".join(tail))


def base_row(task: RunTask) -> ResultRow:
    return ResultRow(id=task.id, cell=task.cell, seed=task.seed, fault_class=task.fault_class,
                     detector=task.detector, span_days=task.span_days)


@dataclass(frozen=True)
class RunOutcome:
    """What a worker hands back: the row, and the weight histories the task asked for."""

    row: ResultRow
    weights: dict[str, RunWeights] | None = None


def _monitor_blocks(result: RunResult, monitors: dict[str, dict]) -> dict[str, MonitorBlock]:
    # monitor_summaries reads the summary in its JSON form and gives, per network, an anomaly
    # block or {"error": record}
    as_json = dataclasses.replace(result, summary=result.summary.to_json())
    return {net: MonitorBlock(anomaly=v) if isinstance(v, AnomalyBlock) else MonitorBlock(error=v["error"])
            for net, v in monitor_summaries(as_json, monitors).items()}


def execute(task: RunTask) -> RunOutcome:
    """Run one campaign run (see the module docstring)."""
    t0 = time.perf_counter()
    row = dataclasses.replace(base_row(task), host=socket.gethostname(), pid=os.getpid())
    weights = None
    try:
        cfg = typed.decode(ScenarioConfig, task.scenario)
        result = run_in_process(cfg, task.seed, fault_label=task.fault_label, run_id=task.id)
        if task.extract_weights:
            weights = {net: weight_history(result, net) for net in task.extract_weights}
        summary = result.summary
        if task.monitors:
            summary = dataclasses.replace(summary, monitors=_monitor_blocks(result, task.monitors))
        row = dataclasses.replace(row, status="ok", error=None, summary=summary)
        del result
    except Exception as exc:  # a failed run is data for the campaign, not the end of it
        row = dataclasses.replace(row, status="failed", error=error_record(exc), summary=None)
    return RunOutcome(dataclasses.replace(row, wall_time_s=time.perf_counter() - t0,
                                          finished_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())),
                      weights)

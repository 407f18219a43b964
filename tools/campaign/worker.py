"""What a campaign worker does with one run: fly it in process and return one result row.

The function is importable by name (``tools.campaign.worker.execute``) so a spawned process pool
and a dask worker run the same code. Its input and output are declared records: a
:class:`~tools.campaign.task.RunTask` in, a :class:`RunOutcome` out — the
:class:`~ground.report.row_types.ResultRow` (the run's summary, id, cell, seed, status, error, wall
time) and, on request, gating networks' weight histories as compact arrays and the run's MCAP
recording (campaigns' ``keep_mcap``) — never the run's messages as objects, ~10^5 for a 45-day run.

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
from typing import Sequence

import numpy as np

from fsw.fdir.config import DetectorConfig
from fsw.core.telemetry import AnomalyReporter
from fsw.fdir.detector import AnomalyDetector
from fsw.fdir.errors import FdirInputError
from fsw.fdir.families import FilterFamily
from fsw.interface import messages as m, topics, typed
from ground.report.row_types import ResultRow
from ground.report.run_facts import anomaly_summary
from ground.report.run_weights import RunWeights
from ground.report.summary_types import ErrorRecord, MonitorBlock
from tools.campaign.run_mcap import keeps, mcap_bytes
from tools.campaign.task import RunTask
from tools.inprocess import RunResult, collector_held, run_in_process
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


def monitor_summaries(result: RunResult, monitors: dict[str, dict]) -> dict[str, MonitorBlock]:
    """``summary.monitors``: the anomaly block of every monitored network of the run. A detector
    that rejects the run's weights (another bank, bad values) gives an error block for that
    network instead of ending the run."""
    a = result.summary.anomaly
    families = result.config.fsw.families()
    t0 = float(result.summary.t0)
    out: dict[str, MonitorBlock] = {}
    for net, cal_data in monitors.items():
        try:
            cal = typed.decode(DetectorConfig, cal_data)
            reports = replay_detector(result.messages, cal, families, t0)
        except (FdirInputError, ValueError, typed.DecodeError) as exc:
            out[net] = MonitorBlock(error=error_record(exc))
            continue
        out[net] = MonitorBlock(anomaly=anomaly_summary(reports, onset_true=a.onset_true, true_class=a.true_class, t0=t0))
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
    mcap: bytes | None = None  # the run's recording, when the task's keep_mcap keeps it


def execute(task: RunTask) -> RunOutcome:
    """Run one campaign run (see the module docstring)."""
    t0 = time.perf_counter()
    c0 = time.process_time()
    row = dataclasses.replace(base_row(task), host=socket.gethostname(), pid=os.getpid())
    weights: dict[str, RunWeights] | None = None
    recording: bytes | None = None
    try:
        with collector_held():  # the run and what is read out of its messages
            row, weights, recording = _fly(task, row)
    except Exception as exc:  # a failed run is data for the campaign, not the end of it
        row = dataclasses.replace(row, status="failed", error=error_record(exc), summary=None)
    return RunOutcome(dataclasses.replace(row, wall_time_s=time.perf_counter() - t0, cpu_time_s=time.process_time() - c0,
                                          finished_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())),
                      weights, recording)


def _fly(task: RunTask, row: ResultRow) -> tuple[ResultRow, dict[str, RunWeights] | None, bytes | None]:
    weights = None
    recording = None
    cfg = typed.decode(ScenarioConfig, task.scenario)
    result = run_in_process(cfg, task.seed, fault_label=task.fault_label, run_id=task.id)
    if task.extract_weights:
        weights = {net: weight_history(result, net) for net in task.extract_weights}
    summary = result.summary
    if task.monitors:
        summary = dataclasses.replace(summary, monitors=monitor_summaries(result, task.monitors))
    if keeps(task.keep_mcap, summary):
        recording = mcap_bytes(result, task.id)
    return dataclasses.replace(row, status="ok", error=None, summary=summary), weights, recording

"""A campaign's result row as a declared record: one line of ``runs.jsonl``.

The worker returns one per run, the store appends it, the statistics read them back. The JSON
form is the one campaigns have always written (key order included), so existing campaign
directories load unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from fsw.interface.typed import spec
from ground.report.json_record import JsonRecord
from ground.report.summary_types import ErrorRecord, RunSummary


@dataclass(frozen=True)
class Cell(JsonRecord):
    """One cell of a campaign matrix: scenario x fault case x network variant."""

    scenario: str = spec(doc="scenario name")
    fault: str = spec(doc="fault case label")
    variant: str = spec(doc="network variant name")

    @property
    def key(self) -> str:
        return f"{self.scenario} / {self.fault} / {self.variant}"


@dataclass(frozen=True)
class DetectorFacts(JsonRecord):
    """The detector a run flew: its network, whether it was calibrated, and the networks of the
    further detectors (monitors) replayed on the run."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"monitors"})

    network: str = spec(doc="gating network the onboard detector watches")
    calibrated: bool = spec(doc="the detector has a calibration (an uncalibrated one cannot declare)")
    monitors: tuple[str, ...] | None = spec(None, doc="monitored networks, None without monitors")


@dataclass(frozen=True)
class ResultRow(JsonRecord):
    """One finished run of a campaign. ``host`` and ``pid`` name the worker (absent when the
    executor lost the run); ``campaign`` and ``executor`` are added by the runner."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"host", "pid", "campaign", "executor", "cpu_time_s"})

    id: str = spec(doc="run id: hash of the resolved scenario and seed")
    cell: Cell = spec(doc="the run's cell")
    seed: int = spec(doc="random seed")
    fault_class: str = spec(doc="injected anomaly class, 'none' without a fault")
    detector: DetectorFacts = spec(doc="the onboard detector and the monitors")
    span_days: float = spec(doc="length of the run", unit="d")
    host: str | None = spec(None, doc="worker host")
    pid: int | None = spec(None, doc="worker process id")
    status: str = spec("ok", doc="'ok' or 'failed'")
    error: ErrorRecord | None = spec(None, doc="why the run failed")
    summary: RunSummary | None = spec(None, doc="the run's summary (None when it failed)")
    wall_time_s: float | None = spec(None, doc="wall-clock time of the run", unit="s")
    cpu_time_s: float | None = spec(None, doc="CPU time of the run in its worker process", unit="s")
    finished_utc: str = spec("", doc="when the run finished, ISO 8601 UTC")
    campaign: str | None = spec(None, doc="campaign name")
    executor: str | None = spec(None, doc="executor that ran it: 'local' or 'dask'")

    @property
    def ok(self) -> bool:
        return self.status == "ok" and self.summary is not None

"""A campaign task: one run as the worker receives it (plain data, pickles the same for a process
pool and for dask)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from fsw.interface.typed import spec
from ground.report.json_record import JsonRecord
from ground.report.row_types import Cell, DetectorFacts


@dataclass(frozen=True)
class RunTask(JsonRecord):
    """One run: its cell, seed and fully resolved scenario."""

    id: str = spec(doc="run id: hash of the resolved scenario, the seed and the monitors")
    cell: Cell = spec(doc="the run's cell")
    seed: int = spec(doc="random seed")
    scenario: dict[str, Any] = spec(doc="the resolved scenario, as ScenarioConfig data")
    fault_label: str | None = spec(doc="fault preset or case label, None for a nominal run")
    fault_class: str = spec(doc="injected anomaly class, 'none' without a fault")
    detector_network: str = spec(doc="gating network of the onboard detector")
    detector_calibrated: bool = spec(doc="the onboard detector has a calibration")
    span_days: float = spec(doc="length of the run", unit="d")
    extract_weights: tuple[str, ...] = spec((), doc="networks whose weight histories the run keeps")
    keep_mcap: str = spec("none", doc="which runs keep an MCAP recording: none, failed, detected, all")
    monitors: dict[str, dict[str, Any]] = spec(default_factory=dict,
                                               doc="monitored network -> DetectorConfig data")

    @property
    def detector(self) -> DetectorFacts:
        return DetectorFacts(network=self.detector_network, calibrated=self.detector_calibrated,
                             monitors=tuple(self.monitors) if self.monitors else None)

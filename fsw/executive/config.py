"""Configuration of the frame executive: frame length, budget, accounting mode, scheduling policy."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from fsw.interface.typed import spec

#: Priority classes, highest priority first (DESIGN.md "Frame executive").
PRIORITY_CLASSES: tuple[str, ...] = ("ingest", "primary", "filters", "gating", "telemetry")
StageKind = Literal["ingest", "primary", "filters", "gating", "telemetry"]

BudgetMode = Literal["cpu", "work-units"]
SchedulingPolicy = Literal["priority", "fifo"]


@dataclass(frozen=True, slots=True)
class BudgetConfig:
    """Frame executive: fixed simulated frame length with a processing budget per frame.

    ``mode = "cpu"`` charges each stage its measured thread CPU time multiplied by ``cpu_scale``
    (a value > 1 emulates a flight processor slower than the host) against ``cpu_budget_s``.
    The defaults emulate a flight processor 10× slower than the host, of which the navigation
    software may use 0.15 s per 60-s frame (a quarter of a percent). The three-filter InSight
    bank needs ≈ 0.6 ms of host CPU per measurement (median; 1.6 ms at the 99th percentile, up
    to 10 ms for the first measurement and the last hours before entry) and never more than two
    measurements fall in one frame, so the busiest frames use well under the budget; at a
    quarter of it the heavier measurements no longer fit two to a frame and tracking passes
    build a backlog that the gaps between passes catch up.
    ``mode = "work-units"`` charges each stage its declared cost against ``work_unit_budget``;
    nothing depends on the host's speed, so runs are reproducible frame by frame.

    ``policy = "priority"`` runs, at every step, the highest-priority stage whose ordering
    constraints are met (so the primary filter runs ahead of lagging secondary filters);
    ``policy = "fifo"`` completes the oldest measurement's job before starting the next.
    """

    mode: BudgetMode = spec("cpu", doc="budget accounting: measured thread CPU time, or declared work units")
    policy: SchedulingPolicy = spec(
        "priority",
        doc="priority: highest-priority ready stage first (primary filter runs ahead); "
        "fifo: one measurement job at a time",
    )
    frame_s: float = spec(60.0, doc="simulated length of one frame", unit="s", gt=0.0)
    cpu_budget_s: float = spec(
        0.15, doc="CPU budget per frame on the emulated flight processor (mode cpu)", unit="s", gt=0.0
    )
    cpu_scale: float = spec(
        10.0, doc="flight-processor slowdown: CPU charged = measured host thread CPU x cpu_scale", unit="1", gt=0.0
    )
    work_unit_budget: float = spec(100.0, doc="budget per frame (mode work-units)", unit="work unit", gt=0.0)
    ingest_cost: float = spec(1.0, doc="default cost of an ingest stage", unit="work unit", ge=0.0)
    primary_cost: float = spec(10.0, doc="default cost of a primary-filter stage", unit="work unit", ge=0.0)
    filters_cost: float = spec(10.0, doc="default cost of an other-filter stage", unit="work unit", ge=0.0)
    gating_cost: float = spec(3.0, doc="default cost of a gating stage", unit="work unit", ge=0.0)
    telemetry_cost: float = spec(1.0, doc="default cost of a telemetry stage", unit="work unit", ge=0.0)
    max_backlog: int = spec(
        1000, doc="backlog depth (measurement jobs) above which a frame report raises its warning", ge=0
    )
    cost_gain: float = spec(
        0.2,
        doc="gain of the running mean/deviation of measured stage cost used to admit stages (mode cpu)",
        unit="1",
        gt=0.0,
        le=1.0,
    )
    cost_margin: float = spec(
        3.0,
        doc="a stage is started only if mean + cost_margin x mean-absolute-deviation of its measured "
        "cost fits the remaining budget (mode cpu)",
        unit="1",
        ge=0.0,
    )
    error_log: int = spec(100, doc="number of most recent stage errors kept for inspection", ge=1)

    @property
    def budget(self) -> float:
        """Budget per frame in the units of ``mode`` (scaled CPU seconds or work units)."""
        return self.cpu_budget_s if self.mode == "cpu" else self.work_unit_budget

    def default_cost(self, kind: str) -> float:
        """Declared work-unit cost of a stage of priority class ``kind``."""
        return {
            "ingest": self.ingest_cost,
            "primary": self.primary_cost,
            "filters": self.filters_cost,
            "gating": self.gating_cost,
            "telemetry": self.telemetry_cost,
        }[kind]

"""``plan.json`` as a declared record: the cells and runs a campaign plans, written when it starts
and read back by the statistics (which then know the runs still missing)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from fsw.interface.typed import spec
from ground.report.json_record import JsonRecord
from ground.report.row_types import DetectorFacts


@dataclass(frozen=True)
class PlannedCell(JsonRecord):
    """A cell of the plan; its fault class and detector are those of its runs (absent for a cell
    without runs)."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"fault_class", "detector"})

    scenario: str = spec(doc="scenario name")
    fault: str = spec(doc="fault case")
    variant: str = spec(doc="network variant")
    key: str = spec(doc="'scenario / fault / variant'")
    fault_class: str | None = spec(None, doc="injected anomaly class")
    detector: DetectorFacts | None = spec(None, doc="the detector of the cell's runs")


@dataclass(frozen=True)
class PlannedRun(JsonRecord):
    id: str = spec(doc="run id")
    cell: str = spec(doc="key of the run's cell")
    seed: int = spec(doc="random seed")


@dataclass(frozen=True)
class PlanFile(JsonRecord):
    name: str = spec(doc="campaign name")
    description: str = spec("", doc="campaign description")
    cells: tuple[PlannedCell, ...] = spec((), doc="cells in plan order")
    runs: tuple[PlannedRun, ...] = spec((), doc="runs in plan order")

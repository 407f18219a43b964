"""Units of work the frame executive schedules: jobs made of ordered stages.

A :class:`Job` is the work one measurement causes (ingest it, run the primary filter, the other
filters, the gating networks, publish telemetry). Its stages run in the order given. Each stage
belongs to a *lane* (by default its priority class); stages of one lane run in job order, so a
filter that owns a lane sees its measurements in time order even when the executive runs other
lanes ahead or behind. The executive knows nothing about what a stage does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from fsw.executive.config import PRIORITY_CLASSES, StageKind
from fsw.interface.frozen import fast_init

#: Rank of each priority class: lower runs first.
PRIORITY_RANK: dict[str, int] = {kind: rank for rank, kind in enumerate(PRIORITY_CLASSES)}


class JobError(ValueError):
    """A job or stage is malformed (unknown priority class, non-finite time or cost, no stages)."""


class JobOrderError(JobError):
    """A job was submitted with a time tag earlier than a job already submitted."""


@dataclass(frozen=True, slots=True)
class Stage:
    """One indivisible step of a job.

    Attributes
    ----------
    kind : str
        Priority class, one of ``PRIORITY_CLASSES``.
    fn : callable
        The work; called with the job's ``context`` if it has one, else with no arguments; its
        return value is ignored. An exception it raises is contained by the executive (counted
        and reported), never propagated.
    lane : str | None
        Ordering lane: stages sharing a lane run in job (time) order. Defaults to ``kind``;
        give each filter its own lane (e.g. ``"filter:optical"``) when filters may progress
        independently.
    cost : float | None
        Declared cost in work units (mode ``work-units``); ``None`` takes the configured
        default of ``kind``.
    name : str | None
        Label in error reports and the key of the measured-cost estimate (mode ``cpu``);
        defaults to the lane.
    """

    kind: StageKind
    fn: Callable[..., object]
    lane: str | None = None
    cost: float | None = None
    name: str | None = None
    #: the lane this stage queues in, and the label it reports under (set from the fields above;
    #: read for every stage the executive runs, so worked out once)
    lane_key: str = field(init=False, repr=False, compare=False)
    label: str = field(init=False, repr=False, compare=False)
    #: rank of the priority class (lower runs first)
    rank: int = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        lane_key = self.lane if self.lane is not None else self.kind
        object.__setattr__(self, "lane_key", lane_key)
        object.__setattr__(self, "label", self.name if self.name is not None else lane_key)
        if self.kind not in PRIORITY_RANK:
            raise JobError(f"stage kind {self.kind!r} is not one of {', '.join(PRIORITY_CLASSES)}")
        object.__setattr__(self, "rank", PRIORITY_RANK[self.kind])
        if not callable(self.fn):
            raise JobError(f"stage {self.label!r}: fn is not callable")
        if self.cost is not None:
            if isinstance(self.cost, bool) or not isinstance(self.cost, (int, float)):
                raise JobError(f"stage {self.label!r}: cost must be a number, got {self.cost!r}")
            if not math.isfinite(self.cost) or self.cost < 0.0:
                raise JobError(f"stage {self.label!r}: cost must be finite and >= 0, got {self.cost!r}")


@fast_init
@dataclass(frozen=True, slots=True)
class Job:
    """The ordered stages caused by one measurement (or any other time-tagged event).

    ``t`` orders the backlog (FIFO by measurement time) and decides the frame from which the job
    is due: a job runs only in frames ending at or after ``t``. ``tag`` is free text carried into
    error reports (e.g. the measurement sequence number). ``context``, when not None, is handed
    to every stage's ``fn``: jobs of the same kind can then share one tuple of stages, built and
    validated once, and differ only in what they work on (one measurement's data).
    """

    t: float
    stages: tuple[Stage, ...]
    tag: str = ""
    context: object = None

    def __post_init__(self) -> None:
        t = self.t
        if type(t) is not float and (isinstance(t, bool) or not isinstance(t, (int, float))):
            raise JobError(f"job time tag must be a finite number, got {t!r}")
        if not math.isfinite(t):
            raise JobError(f"job time tag must be a finite number, got {t!r}")
        if not isinstance(self.stages, tuple) or not self.stages:
            raise JobError("a job needs a non-empty tuple of stages")
        for stage in self.stages:
            if not isinstance(stage, Stage):
                raise JobError(f"job stages must be Stage instances, got {type(stage).__name__}")

"""The work one measurement causes onboard, as a table of stages.

Each measurement becomes one executive job. Its stages run in the order of the table; each row
names the priority class, the label the executive reports (and, in CPU mode, keys its measured
cost by), the core's method that does the work and the rule for its declared cost in work units.
The cost rules depend only on the load when the job is queued: how many filters are enabled and
how many gating networks run.
"""

from __future__ import annotations

import gc
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from typing import Callable, Generic, Iterator, TypeVar

from fsw.executive import Job, Stage
from fsw.executive.config import BudgetConfig, StageKind
from fsw.filters.record import BankRecord
from fsw.interface import messages as m

Core = TypeVar("Core")


@dataclass(slots=True)
class JobContext:
    """What the stages of one measurement's job hand on to each other."""

    meas: m.Measurement
    record: BankRecord | None = None  # the bank's record; None when the bank rejected it


@dataclass(frozen=True)
class Load:
    """What the declared stage costs depend on."""

    active_filters: int
    networks: int
    adaptive_lp: float = 0.0  # work units of the FLR slope fits of the enabled fuzzy-adaptive filters


def ingest_cost(budget: BudgetConfig, load: Load) -> float:
    return budget.ingest_cost


def bank_cost(budget: BudgetConfig, load: Load) -> float:
    """The bank advances every enabled filter in one vectorised stage (they share the
    propagation of the union state): one primary filter plus an increment per further filter, plus
    the linear programs of fuzzy-adaptive process noise, which run inside the update."""
    return budget.primary_cost + budget.filters_cost * max(load.active_filters - 1, 0) + load.adaptive_lp


def gating_cost(budget: BudgetConfig, load: Load) -> float:
    return budget.gating_cost * max(load.networks, 1)


def telemetry_cost(budget: BudgetConfig, load: Load) -> float:
    return budget.telemetry_cost


@dataclass(frozen=True)
class StageSpec(Generic[Core]):
    """One row of the pipeline table."""

    kind: StageKind
    label: str | None  # None: the priority class
    run: Callable[[Core, JobContext], None]
    cost: Callable[[BudgetConfig, Load], float]


def build_stages(core: Core, pipeline: tuple[StageSpec[Core], ...], budget: BudgetConfig,
                 load: Load) -> tuple[Stage, ...]:
    """The pipeline's stages bound to ``core``, costed for ``load``; each takes the job's
    :class:`JobContext`. They depend on nothing else, so a core builds them once per load."""
    return tuple(Stage(s.kind, partial(s.run, core), cost=s.cost(budget, load), name=s.label) for s in pipeline)


def build_job(core: Core, pipeline: tuple[StageSpec[Core], ...], meas: m.Measurement,
              budget: BudgetConfig, load: Load, stages: tuple[Stage, ...] | None = None) -> Job:
    """The job of ``meas``: the pipeline's stages bound to ``core`` (``stages``, if the caller
    has them from :func:`build_stages`) and one context they share."""
    if stages is None:
        stages = build_stages(core, pipeline, budget, load)
    return Job(t=meas.t_s, stages=stages, tag=str(meas.seq), context=JobContext(meas))


@contextmanager
def no_gc_pauses() -> Iterator[None]:
    """Keep Python's cyclic garbage collector out of the frames.

    A full collection costs tens of ms — longer than any stage — and would land on whatever stage
    happens to allocate at that moment, charging it a spurious overrun. Collection is deferred
    to just after the frame, outside any stage's CPU accounting (a flight executive likewise
    keeps memory management out of its time-critical frames)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()

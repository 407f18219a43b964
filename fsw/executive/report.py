"""What the frame executive reports: per-frame budget telemetry, cumulative statistics, errors."""

from __future__ import annotations

from dataclasses import dataclass

from fsw.executive.config import BudgetMode
from fsw.interface.frozen import fast_init

#: Fields of :class:`BudgetReportData` that map one-to-one onto the ICD ``BudgetReport``.
ICD_FIELDS: tuple[str, ...] = (
    "frame", "t_s", "mode", "used", "budget", "utilisation",
    "processed", "deferred", "backlog", "overruns", "errors",
)


@fast_init
@dataclass(frozen=True, slots=True)
class BudgetReportData:
    """Budget telemetry of one frame.

    ``used`` and ``budget`` are scaled CPU seconds in mode ``cpu`` and work units in mode
    ``work-units``. ``processed`` counts stages completed in the frame; ``deferred`` counts the
    stages that were due (their job's time tag is not after the frame end) but did not run and
    move to a later frame; ``backlog`` counts the due measurement jobs with a stage outstanding.
    ``overruns`` and ``errors`` are cumulative. ``lag_s`` is how far the oldest outstanding due
    job lies behind the frame end (0 with no backlog).
    """

    frame: int
    t_s: float
    mode: BudgetMode
    used: float
    budget: float
    utilisation: float
    processed: int
    deferred: int
    backlog: int
    overruns: int
    errors: int
    lag_s: float
    backlog_warning: bool

    def icd_fields(self) -> dict:
        """Keyword arguments for the ICD ``BudgetReport`` (the caller adds ``timestamp``)."""
        # spelled out: one per reported frame, and a dict display is several times cheaper than
        # getattr over ICD_FIELDS (tests/test_executive_budget.py checks the two agree)
        return {"frame": self.frame, "t_s": self.t_s, "mode": self.mode, "used": self.used, "budget": self.budget,
                "utilisation": self.utilisation, "processed": self.processed, "deferred": self.deferred,
                "backlog": self.backlog, "overruns": self.overruns, "errors": self.errors}


@dataclass(frozen=True, slots=True)
class StageError:
    """A stage raised: where, when, and what."""

    frame: int
    t_job: float
    tag: str
    stage: str
    kind: str
    error: str


@dataclass(frozen=True, slots=True)
class ExecutiveStats:
    """Cumulative counters since the executive was created."""

    frames: int
    submitted: int
    rejected: int
    jobs_completed: int
    stages_run: int
    overruns: int
    errors: int
    callback_errors: int
    backlog: int
    pending_jobs: int
    max_backlog_seen: int
    backlog_warnings: int
    used_total: float
    budget_total: float
    cpu_measured_s: float


@dataclass(frozen=True, slots=True)
class DrainResult:
    """Outcome of :meth:`FrameExecutive.drain`: the extra frames it took and what is left."""

    frames: int
    reports: tuple[BudgetReportData, ...]
    remaining_jobs: int

"""The frame executive: runs submitted jobs in frames of fixed simulated length within a budget.

Frame k (0-based) covers simulated time up to its end epoch; by default frame ends fall every
``frame_s`` seconds after ``t0``. A frame runs only jobs whose time tag is not after its end
(a measurement is not processed before it exists). Within the frame, stages are picked by the
scheduling policy (:mod:`fsw.executive.schedule`) and charged by the meter
(:mod:`fsw.executive.meter`) until the next stage's predicted cost no longer fits the remaining
budget. What does not fit stays queued — nothing is dropped — and later frames, idle ones
included, spend their budget on that backlog first-come first-served by measurement time.

An *overrun* is a stage whose charged cost exceeded the budget remaining when it started: a
stage larger than a whole frame (it runs alone at the start of a frame, so the executive cannot
stall), or in CPU mode a stage that took longer than predicted. The overrun frame reports a
utilisation above 1; the next frame starts with its full budget.

A stage that raises is contained: the error is counted, kept in :attr:`FrameExecutive.errors`,
passed to ``on_error``, and the job continues with its next stage (later stages decide what to
do with missing results; silently skipping them would lose the measurement for every filter).

Threading: :meth:`submit` may be called from any thread; :meth:`run_frame` and :meth:`drain`
from one thread only — the CPU clock measures the calling thread.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from typing import Any, Callable

from fsw.executive.config import BudgetConfig
from fsw.executive.meter import CpuMeter, WorkUnitMeter
from fsw.executive.report import BudgetReportData, DrainResult, ExecutiveStats, StageError
from fsw.executive.schedule import JobState, StageQueue
from fsw.executive.work import Job, JobError, JobOrderError, Stage


class FrameTimeError(ValueError):
    """A frame end epoch is not finite or not after the previous frame end."""


class FrameExecutive:
    """Fixed-budget frame executive for time-tagged jobs of prioritised, ordered stages.

    Parameters
    ----------
    config : BudgetConfig
        Frame length, budget, accounting mode and scheduling policy.
    clock : callable
        CPU clock of the calling thread, in seconds (``time.thread_time``); injectable for tests.
    t0 : float
        Simulated epoch of the start of frame 0 [s]; frame k ends at ``t0 + (k+1) frame_s``
        unless :meth:`run_frame` is given explicit end epochs.
    on_error : callable, optional
        Called with a :class:`StageError` for every stage that raises.
    """

    # Slotted, like the queue and the meters: the executive is copied (the FSW core's start-up
    # warm-up) and pickled (checkpoints) in flight, and on CPython 3.11 copying or pickling an
    # object that keeps its attributes in a plain instance dictionary turns that dictionary into
    # a real dict object for good, which makes every later attribute access on it slower (3 µs
    # a measurement, summed over the executive's per-stage bookkeeping). Slots are read
    # one by one, leaving nothing to convert.
    __slots__ = ("config", "_clock", "_on_error", "_meter", "_queue", "_future", "_lock", "_running", "_t_end",
                 "_t_running", "_last_t", "_frame", "_errors", "_lane_progress", "_submitted", "_rejected",
                 "_jobs_completed", "_stages_run", "_overruns", "_error_count", "_callback_errors",
                 "_max_backlog_seen", "_backlog_warnings", "_used_total", "_budget_total", "_cpu_measured")

    def __init__(
        self,
        config: BudgetConfig | None = None,
        clock: Callable[[], float] = time.thread_time,
        *,
        t0: float = 0.0,
        on_error: Callable[[StageError], object] | None = None,
    ):
        self.config = config if config is not None else BudgetConfig()
        if not isinstance(t0, (int, float)) or not math.isfinite(t0):
            raise FrameTimeError(f"t0 must be a finite number, got {t0!r}")
        self._clock = clock
        self._on_error = on_error
        self._meter = CpuMeter(self.config) if self.config.mode == "cpu" else WorkUnitMeter(self.config)
        self._queue = StageQueue(self.config.policy)
        self._future: deque[JobState] = deque()
        self._lock = threading.Lock()
        self._running = False
        self._t_end = float(t0)
        self._t_running = float(t0)
        self._last_t: float | None = None
        self._frame = 0
        self._errors: deque[StageError] = deque(maxlen=self.config.error_log)
        self._lane_progress: dict[str, float] = {}
        self._submitted = 0
        self._rejected = 0
        self._jobs_completed = 0
        self._stages_run = 0
        self._overruns = 0
        self._error_count = 0
        self._callback_errors = 0
        self._max_backlog_seen = 0
        self._backlog_warnings = 0
        self._used_total = 0.0
        self._budget_total = 0.0
        self._cpu_measured = 0.0

    # ------------------------------------------------------------------ submission

    # A checkpoint (fsw.core.checkpoint) pickles the executive with its backlog; a lock is the one
    # thing that cannot travel, and a fresh one is what a resumed process needs anyway.
    def __getstate__(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in self.__slots__ if name != "_lock"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        for name, value in state.items():
            setattr(self, name, value)
        self._lock = threading.Lock()

    def submit(self, job: Job) -> None:
        """Queue ``job``. Jobs must be submitted in non-decreasing time-tag order.

        Raises :class:`JobError` for a non-Job and :class:`JobOrderError` for a job older than
        one already submitted (both counted as rejected; the executive's state is unchanged).
        """
        with self._lock:
            if not isinstance(job, Job):
                self._rejected += 1
                raise JobError(f"expected a Job, got {type(job).__name__}")
            if self._last_t is not None and job.t < self._last_t:
                self._rejected += 1
                raise JobOrderError(
                    f"job at t={job.t!r} submitted after a job at t={self._last_t!r}; "
                    "the backlog is FIFO by time tag"
                )
            self._last_t = float(job.t)
            self._future.append(JobState(job, self._submitted))
            self._submitted += 1

    def _promote(self, t_end: float) -> None:
        with self._lock:
            future = self._future
            while future and future[0].job.t <= t_end:
                self._queue.add(future.popleft())

    # ------------------------------------------------------------------ frames
    @property
    def t_frame_end(self) -> float:
        """End epoch of the last frame run (``t0`` before the first)."""
        return self._t_end

    @property
    def t_now(self) -> float:
        """The executive's clock: inside a stage, the end epoch of the frame running it (work
        done in a frame is known onboard by its end); outside, the end of the last frame."""
        return self._t_running if self._running else self._t_end

    @property
    def frame(self) -> int:
        """Index of the next frame to run (= number of frames run)."""
        return self._frame

    def run_frame(self, t_frame_end: float | None = None) -> BudgetReportData:
        """Run one frame ending at ``t_frame_end`` (default: previous end + ``frame_s``)."""
        if self._running:
            raise RuntimeError("run_frame called from inside a stage")
        if t_frame_end is None:
            t_end = self._t_end + self.config.frame_s  # a float: only its value needs checking
            if not self._t_end < t_end < math.inf:
                raise FrameTimeError(f"frame end {t_end!r} is not finite and after the previous frame end "
                                     f"{self._t_end!r}")
        else:
            t_end = t_frame_end
            if isinstance(t_end, bool) or not isinstance(t_end, (int, float)) or not math.isfinite(t_end):
                raise FrameTimeError(f"frame end must be a finite number, got {t_end!r}")
            t_end = float(t_end)
            if t_end <= self._t_end:
                raise FrameTimeError(f"frame end {t_end!r} is not after the previous frame end {self._t_end!r}")
        self._running = True
        self._t_running = t_end
        try:
            return self._run(t_end)
        finally:
            self._running = False

    def run_until(self, t: float) -> list[BudgetReportData]:
        """Run every frame of the regular cadence that ends at or before ``t``."""
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise FrameTimeError(f"run_until needs a finite epoch, got {t!r}")
        reports = []
        while self._t_end + self.config.frame_s <= t:
            reports.append(self.run_frame())
        return reports

    def drain(self, max_frames: int | None = None) -> DrainResult:
        """Run frames until every submitted job is complete (end of run).

        Frames keep the regular cadence; a stretch with nothing due (jobs tagged far ahead) is
        skipped to the first frame boundary at or after the next job. ``max_frames`` bounds the
        number of frames; ``remaining_jobs`` of the result says what, if anything, is left.
        """
        reports: list[BudgetReportData] = []
        frame_s = self.config.frame_s
        while self.pending_jobs:
            if max_frames is not None and len(reports) >= max_frames:
                break
            t_end = self._t_end + frame_s
            if self._queue.pending_jobs == 0:
                with self._lock:
                    t_next = self._future[0].job.t if self._future else t_end
                if t_next > t_end:
                    t_end = self._t_end + math.ceil((t_next - self._t_end) / frame_s) * frame_s
                    t_end = max(t_end, t_next)  # rounding must not leave the job undue
            reports.append(self.run_frame(t_end))
        return DrainResult(frames=len(reports), reports=tuple(reports), remaining_jobs=self.pending_jobs)

    def skip_idle(self, until: float, before: float = math.inf) -> int:
        """Pass, without reports, the frames of the regular cadence that end at or before
        ``until`` and before ``before`` and in which nothing is due (no job queued, none tagged at
        or before the frame's end); returns how many.

        Such a frame runs nothing, uses nothing and defers nothing: this leaves the executive as
        :meth:`run_frame` would for each of them, at the cost of an addition per frame (tracking
        gaps are days of idle frames). The caller says with ``before`` from where on it wants the
        frames' reports (e.g. a periodic idle report)."""
        if self._running:
            raise RuntimeError("skip_idle called from inside a stage")
        frame_s, budget = self.config.frame_s, self.config.budget
        nxt = self._t_end + frame_s
        if self._queue.pending_jobs or nxt > until or nxt >= before:
            return 0  # asked before every frame: most often not even the next frame may be skipped
        with self._lock:
            t_due = self._future[0].job.t if self._future else math.inf
        t_end, skipped, budget_total = self._t_end, 0, self._budget_total
        while True:
            nxt = t_end + frame_s
            if nxt > until or nxt >= before or nxt >= t_due:
                break
            t_end = nxt
            skipped += 1
            budget_total += budget  # added frame by frame, as run_frame adds it
        self._t_end, self._budget_total = t_end, budget_total
        self._frame += skipped
        return skipped

    def _run(self, t_end: float) -> BudgetReportData:
        self._promote(t_end)
        frame = self._frame
        queue, meter, clock = self._queue, self._meter, self._clock
        peek, oldest, complete, fits, charge = queue.peek, queue.oldest, queue.complete, meter.fits, meter.charge
        lane_progress = self._lane_progress
        budget = self.config.budget
        used = 0.0
        processed = 0
        full = False
        # One clock reading per stage: the end of one stage is the start of the next, so the
        # executive's own bookkeeping between them is charged to the stage it leads to.
        mark: float | None = None
        fifo = queue.fifo
        while not full:
            # The stages to run next, in order: the rest of one job while the policy would pick
            # them one after the other anyway (the usual frame: one measurement's job), else the
            # policy's one pick (StageQueue.single, spelled out: asked for every job of a frame).
            if fifo or queue.pending_jobs <= 1:
                state = oldest()
                if state is None:
                    break
                first = state.next
                last = len(state.job.stages)
            else:
                picked = peek()
                if picked is None:
                    break
                state, first = picked
                last = first + 1
            job = state.job
            stages, context, t_job = job.stages, job.context, float(job.t)
            for index in range(first, last):
                stage = stages[index]
                remaining = budget - used
                if processed and not fits(stage, remaining):
                    full = True
                    break
                start = clock() if mark is None else mark
                try:
                    if context is None:
                        stage.fn()
                    else:
                        stage.fn(context)
                except Exception as exc:  # a faulty stage must never stop the executive
                    self._record_error(frame, state, stage, exc)
                mark = clock()
                measured = mark - start
                if not 0.0 <= measured < math.inf:
                    measured = 0.0  # a clock that misbehaves (NaN, infinite, backwards) charges nothing
                self._cpu_measured += measured
                cost = charge(stage, measured)
                if cost > remaining:
                    self._overruns += 1
                used += cost
                processed += 1
                if complete(state, index):
                    self._jobs_completed += 1
                lane_progress[stage.lane_key] = t_job
        self._stages_run += processed
        self._t_end = t_end
        self._frame += 1
        backlog = queue.pending_jobs
        behind = oldest()
        warning = backlog > self.config.max_backlog
        if backlog > self._max_backlog_seen:
            self._max_backlog_seen = backlog
        self._backlog_warnings += int(warning)
        self._used_total += used
        self._budget_total += budget
        # by position, in the declaration's order (one per frame)
        return BudgetReportData(frame, t_end, self.config.mode, used, budget, used / budget, processed,
                                queue.pending_stages, backlog, self._overruns, self._error_count,
                                (t_end - behind.job.t) if behind is not None else 0.0, warning)

    def _record_error(self, frame: int, state: JobState, stage: Stage, exc: Exception) -> None:
        self._error_count += 1
        error = StageError(
            frame=frame,
            t_job=float(state.job.t),
            tag=state.job.tag,
            stage=stage.label,
            kind=stage.kind,
            error=f"{type(exc).__name__}: {exc}",
        )
        self._errors.append(error)
        if self._on_error is not None:
            try:
                self._on_error(error)
            except Exception:
                self._callback_errors += 1

    # ------------------------------------------------------------------ inspection
    @property
    def backlog(self) -> int:
        """Due jobs with a stage outstanding."""
        return self._queue.pending_jobs

    @property
    def pending_jobs(self) -> int:
        """All jobs with a stage outstanding, due or not yet due."""
        with self._lock:
            return self._queue.pending_jobs + len(self._future)

    def pending_with(self, label: str) -> int:
        """Jobs, due or not yet due, with a stage labelled ``label`` still to run: under the
        priority policy a job whose primary stage has run may wait frames for its gating and
        telemetry, and counts in :attr:`pending_jobs` all that time."""
        with self._lock:
            future = sum(1 for state in self._future if any(stage.label == label for stage in state.job.stages))
            return future + self._queue.pending_with(label)

    @property
    def errors(self) -> tuple[StageError, ...]:
        """The most recent stage errors (at most ``config.error_log``)."""
        return tuple(self._errors)

    def lane_progress(self) -> dict[str, float]:
        """Time tag of the newest job whose stage in each lane has run: how current each lane is."""
        return dict(self._lane_progress)

    def stage_cpu(self) -> dict[str, tuple[int, float]]:
        """Mode ``cpu``: (stages run, thread CPU seconds measured in them) per stage label; empty
        in mode ``work-units`` (declared costs say nothing of the host's CPU)."""
        return self._meter.cpu_by_label() if isinstance(self._meter, CpuMeter) else {}

    def cost_estimates(self) -> dict[str, tuple[float, float]]:
        """Mode ``cpu``: (mean, mean absolute deviation) of charged cost per stage label."""
        return self._meter.estimates() if isinstance(self._meter, CpuMeter) else {}

    @property
    def stats(self) -> ExecutiveStats:
        with self._lock:
            submitted, rejected, future = self._submitted, self._rejected, len(self._future)
        return ExecutiveStats(
            frames=self._frame,
            submitted=submitted,
            rejected=rejected,
            jobs_completed=self._jobs_completed,
            stages_run=self._stages_run,
            overruns=self._overruns,
            errors=self._error_count,
            callback_errors=self._callback_errors,
            backlog=self._queue.pending_jobs,
            pending_jobs=self._queue.pending_jobs + future,
            max_backlog_seen=self._max_backlog_seen,
            backlog_warnings=self._backlog_warnings,
            used_total=self._used_total,
            budget_total=self._budget_total,
            cpu_measured_s=self._cpu_measured,
        )

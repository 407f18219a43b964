"""Which stage runs next: the ordering rules of the frame executive, with no notion of budget.

Two constraints hold under every policy:

1. the stages of a job run in the order the job lists them (gating for a measurement runs only
   after every filter stage of that measurement);
2. the stages of one lane run in job order, i.e. FIFO by measurement time (a filter sees its
   measurements in time order).

A stage meeting both is *ready*. The oldest outstanding job's next stage is always ready (every
earlier entry of its lane belongs to an older, hence finished, job), so the queue never
deadlocks.

Policies
--------
``priority``
    Run the ready stage of highest priority class, the oldest job breaking ties. With every
    measurement's work fitting in the frame this is "all ingest, then all primary-filter updates,
    then the other filters, gating, telemetry". Under overload the primary filter stays current
    while the other filters, gating and telemetry fall behind and catch up in idle frames — what
    a flight executive does to keep the navigation solution fresh. Each lane remains time
    ordered, so no filter ever processes a measurement older than one it has already processed.
``fifo``
    Complete the oldest job before starting the next: all filters stay synchronised at the price
    of a primary solution that lags as much as the rest.
"""

from __future__ import annotations

from collections import deque

from fsw.executive.work import Job


class JobState:
    """Progress of one submitted job."""

    __slots__ = ("job", "order", "next")

    def __init__(self, job: Job, order: int):
        self.job = job
        self.order = order
        self.next = 0

    @property
    def done(self) -> bool:
        return self.next >= len(self.job.stages)


class StageQueue:
    """Outstanding stages of the due jobs, and the policy that picks the next one."""

    __slots__ = ("_policy", "_lanes", "_jobs", "pending_stages", "pending_jobs")  # see FrameExecutive's

    def __init__(self, policy: str):
        if policy not in ("priority", "fifo"):
            raise ValueError(f"unknown scheduling policy {policy!r}")
        self._policy = policy
        # The lanes: every outstanding stage as (job, stage index), one FIFO per lane key. Only
        # the priority policy with two or more jobs outstanding picks by them; a frame's usual
        # load is one measurement's job, whose stages run in their own order (see peek), and
        # queueing its four stages in lanes only to take them out again cost ~1 µs a job. So the
        # lanes exist only while they can be needed (None otherwise), and are made from the
        # outstanding jobs, in job order — what they would hold had they been kept all along —
        # when a second job joins.
        self._lanes: dict[str, deque[tuple[JobState, int]]] | None = None
        self._jobs: deque[JobState] = deque()
        self.pending_stages = 0
        self.pending_jobs = 0

    def add(self, state: JobState) -> None:
        """Queue a due job; jobs must arrive in order (their lanes stay FIFO)."""
        self._jobs.append(state)
        self.pending_stages += len(state.job.stages)
        self.pending_jobs += 1
        if self._lanes is not None:
            self._enter(self._lanes, state, 0)
        elif self.pending_jobs > 1 and self._policy == "priority":
            lanes: dict[str, deque[tuple[JobState, int]]] = {}
            for queued in self._jobs:
                self._enter(lanes, queued, queued.next)
            self._lanes = lanes

    @staticmethod
    def _enter(lanes: dict[str, deque[tuple[JobState, int]]], state: JobState, first: int) -> None:
        """Append the stages of ``state`` from index ``first`` on to their lanes (made as needed)."""
        stages = state.job.stages
        for index in range(first, len(stages)):
            key = stages[index].lane_key
            lane = lanes.get(key)
            if lane is None:
                lane = lanes[key] = deque()
            lane.append((state, index))

    def pending_with(self, label: str) -> int:
        """Due jobs with a stage labelled ``label`` still to run."""
        return sum(1 for state in self._jobs
                   if not state.done and any(stage.label == label for stage in state.job.stages[state.next:]))

    def oldest(self) -> JobState | None:
        """The oldest job with a stage outstanding."""
        jobs = self._jobs
        while jobs and jobs[0].done:
            jobs.popleft()
        return jobs[0] if jobs else None

    def peek(self) -> tuple[JobState, int] | None:
        """The stage the policy runs next, as (job, stage index), or None when nothing is due."""
        if self._policy == "fifo" or self.pending_jobs <= 1:
            # With one job outstanding (a frame's usual load: one measurement) every lane entry
            # is that job's, and its one ready entry is its next stage: what both policies pick.
            state = self.oldest()
            return None if state is None else (state, state.next)
        # the ready lane head of lowest (priority rank, job order); ranks compared first because
        # they decide almost every comparison
        best: tuple[JobState, int] | None = None
        best_rank = best_order = 0
        lanes = self._lanes
        assert lanes is not None  # kept whenever two or more jobs are outstanding (add)
        for lane in lanes.values():
            if not lane:
                continue
            head = lane[0]
            state, index = head
            if state.next != index:
                continue
            rank = state.job.stages[index].rank
            if best is None or rank < best_rank or (rank == best_rank and state.order < best_order):
                best, best_rank, best_order = head, rank, state.order
        return best

    @property
    def fifo(self) -> bool:
        """Whether the policy is ``fifo`` (every job's stages in job order, one job after the other)."""
        return self._policy == "fifo"

    @property
    def single(self) -> bool:
        """Whether the next stages are one job's, in its order, whichever the policy: under
        ``fifo`` always; under ``priority`` while at most one job is outstanding (its one ready
        lane entry is its next stage). Jobs join only between frames, so a frame that finds
        this true keeps it to its end."""
        return self._policy == "fifo" or self.pending_jobs <= 1

    def complete(self, state: JobState, index: int) -> bool:
        """Mark the stage returned by :meth:`peek` as run; True when that finished its job."""
        lanes = self._lanes
        lane = None
        if lanes is not None:
            lane = lanes[state.job.stages[index].lane_key]
            if not lane or lane[0][0] is not state or lane[0][1] != index:
                raise RuntimeError("stage completed out of order")  # refused: the queue unchanged
        else:
            # without lanes (one job outstanding, or fifo) the stage must be the oldest
            # outstanding job's; finished jobs ahead of it go now rather than at the next oldest()
            jobs = self._jobs
            if not jobs or jobs[0] is not state:
                while jobs and jobs[0].done:
                    jobs.popleft()
                if not jobs or jobs[0] is not state:
                    raise RuntimeError("stage completed out of order")
        if state.next != index:
            raise RuntimeError("stage completed out of order")
        if lane is not None:
            lane.popleft()
        state.next = index + 1
        self.pending_stages -= 1
        if index + 1 >= len(state.job.stages):
            self.pending_jobs -= 1
            if self.pending_jobs <= 1:
                self._lanes = None  # the one job left, if any, runs in its own order
            return True
        return False

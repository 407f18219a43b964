"""Running a campaign plan: resume, submit, collect rows, survive failures and Ctrl-C.

* Resume: runs whose id already has a row in ``runs.jsonl`` are skipped; ``rerun_failed`` runs
  exactly the ids whose latest row failed (their new row supersedes the old one).
* At most ``executor.capacity`` runs are in flight, so stopping submission stops the campaign
  promptly and nothing sits queued inside the executor.
* A run that raises is a ``failed`` row (from the worker); an executor-level failure (a worker
  process that died) is a ``failed`` row written here. Neither stops the campaign.
* SIGINT: the first stops submitting and lets the running runs finish and be recorded; a second
  cancels them (they get no row, so a resumed campaign runs them again). The JSONL stays whole
  either way, and the outcome says it was interrupted (the command exits 130).
"""

from __future__ import annotations

import dataclasses
import signal
import threading
import time
from collections import deque
from concurrent.futures import CancelledError
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, Callable, TextIO

from ground.report.row_types import ResultRow
from tools.campaign.executors import Executor
from tools.campaign.plan import CampaignPlan
from tools.campaign.progress import CampaignProgress
from tools.campaign.store import PLAN, RunStore, write_json_atomic
from tools.campaign.task import RunTask
from tools.campaign.worker import base_row, error_record

if TYPE_CHECKING:
    from typing_extensions import TypeIs

POLL_S = 0.5


@dataclass
class CampaignOutcome:
    planned: int = 0
    skipped: int = 0
    submitted: int = 0
    finished: int = 0
    failed: int = 0
    cancelled: int = 0
    interrupted: bool = False
    repaired_bytes: int = 0
    wall_s: float = 0.0
    executor: str = ""
    workers: int = 0
    failed_ids: list[str] = field(default_factory=list)

    @property
    def runs_per_min(self) -> float:
        return 60.0 * self.finished / self.wall_s if self.wall_s > 0 else 0.0


def select_tasks(plan: CampaignPlan, latest: dict[str, ResultRow], rerun_failed: bool) -> list[RunTask]:
    """The runs to do now: missing ones, or (``rerun_failed``) those whose latest row failed."""
    if rerun_failed:
        return [t for t in plan.tasks if t.id in latest and latest[t.id].status != "ok"]
    return [t for t in plan.tasks if t.id not in latest]


class _Interrupts:
    """Counts SIGINTs while installed (main thread only; elsewhere Ctrl-C keeps its default)."""

    def __init__(self) -> None:
        self.count = 0
        self._prev: Callable[[int, FrameType | None], Any] | int | None = None

    def __enter__(self) -> "_Interrupts":
        if threading.current_thread() is threading.main_thread():
            self._prev = signal.signal(signal.SIGINT, self._handle)
        return self

    def _handle(self, signum, frame) -> None:
        self.count += 1

    def __exit__(self, *exc) -> None:
        if self._prev is not None:
            signal.signal(signal.SIGINT, self._prev)


def _executor_failure_row(task: RunTask, exc: BaseException, campaign: str, executor: str) -> ResultRow:
    return dataclasses.replace(base_row(task), campaign=campaign, executor=executor, status="failed",
                               error=error_record(exc), summary=None, wall_time_s=None,
                               finished_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))


def _is_factory(executor: Executor | Callable[[], Executor]) -> TypeIs[Callable[[], Executor]]:
    """A factory of an executor rather than an executor (which has ``submit``)."""
    return callable(executor) and not hasattr(executor, "submit")


def run_campaign(plan: CampaignPlan, out_dir: str | Path, executor: Executor | Callable[[], Executor], *,
                 rerun_failed: bool = False,
                 progress_stream: TextIO | None = None, on_row: Callable[[ResultRow], None] | None = None,
                 quiet: bool = False) -> CampaignOutcome:
    """Run the plan's missing (or failed) runs into ``out_dir``; see the module docstring.

    ``executor`` may be a factory: it is then called only if there is something to run (a resumed,
    finished campaign starts no cluster) and closed at the end."""
    t0 = time.monotonic()
    owned = None
    out = CampaignOutcome(planned=len(plan.tasks))
    store = RunStore(out_dir)
    out.repaired_bytes = store.open()
    try:
        write_json_atomic(Path(out_dir) / PLAN, plan.plan_file().to_json())
        latest = store.read().latest()
        tasks = select_tasks(plan, latest, rerun_failed)
        out.skipped = len(plan.tasks) - len(tasks)
        if not tasks:
            return out  # nothing to run: no executor is made
        if _is_factory(executor):
            executor = owned = executor()
        out.executor, out.workers = executor.name, executor.capacity
        progress = None if quiet else CampaignProgress(len(tasks), label=plan.name, stream=progress_stream)
        pending = deque(tasks)
        inflight: dict[object, RunTask] = {}
        announced = False
        with _Interrupts() as intr:
            while pending or inflight:
                if intr.count >= 2 and inflight:
                    executor.cancel()
                    out.cancelled = len(inflight)
                    inflight.clear()
                    break
                if intr.count == 0:
                    while pending and len(inflight) < executor.capacity:
                        queued = pending.popleft()
                        inflight[executor.submit(queued)] = queued
                        out.submitted += 1
                elif not announced:
                    announced = True
                    out.interrupted = True
                    if progress:
                        progress.update(running=len(inflight), force=True,
                                        note=f"interrupted: finishing {len(inflight)} running run(s), Ctrl-C again cancels them")
                if intr.count and not inflight:
                    break
                if progress:
                    progress.update(running=len(inflight))
                for handle, result, exc in executor.wait(POLL_S):
                    task = inflight.pop(handle, None)
                    if task is None:
                        continue
                    if exc is not None:
                        if intr.count or isinstance(exc, CancelledError):
                            continue  # not the run's fault: no row, a resumed campaign runs it again
                        row = _executor_failure_row(task, exc, plan.name, executor.name)
                    else:
                        assert result is not None  # a completion has its result or its exception
                        row = dataclasses.replace(result.row, campaign=plan.name, executor=executor.name)
                        if result.weights is not None and row.status == "ok":
                            store.save_weights(task.id, result.weights)
                        if result.mcap is not None and row.status == "ok":
                            store.save_mcap(task.id, result.mcap)
                    store.append(row)
                    ok = row.status == "ok"
                    out.finished += 1
                    if not ok:
                        out.failed += 1
                        out.failed_ids.append(task.id)
                    if on_row is not None:
                        on_row(row)
                    if progress:
                        progress.update(finished=1, failed=0 if ok else 1, running=len(inflight))
            out.interrupted = out.interrupted or intr.count > 0
        if progress:
            progress.close()
    except BaseException:
        if owned is not None:
            owned.cancel()  # do not wait for running runs on the way out of an error
        raise
    finally:
        store.close()
        if owned is not None:
            owned.close()
        out.wall_s = time.monotonic() - t0
    return out

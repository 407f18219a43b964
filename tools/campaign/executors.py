"""Where campaign runs execute: a local process pool or a dask cluster, behind one small interface.

* ``local`` — :class:`concurrent.futures.ProcessPoolExecutor` with the **spawn** start method.
  Never fork: the parent may hold Zenoh sessions and threads (the dask client's, the progress
  line's), and a forked child inherits their locks in whatever state they were in. Workers ignore
  SIGINT, so a Ctrl-C in the terminal (sent to the whole process group) reaches only the campaign
  runner, which decides whether running runs finish or are cancelled. Workers live for the whole
  campaign and are warmed at start (:mod:`tools.campaign.warm`).
* ``dask`` — a ``distributed.Client`` on an existing scheduler (``--scheduler tcp://HOST:PORT``;
  its workers need navbank installed; ``dask worker --preload tools.campaign.warm`` warms them),
  or a ``LocalCluster`` started here on loopback with one single-threaded, warmed worker process
  per ``--workers`` and no dashboard.

Both run :func:`tools.campaign.worker.execute`, so a run gives the same row on either.
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import multiprocessing
import os
import signal
import uuid
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

from tools.campaign.task import RunTask
from tools.campaign.warm import init_worker, quiet_settings
from tools.campaign.worker import RunOutcome, execute

#: (handle, result or None, exception or None)
Completion = tuple[Any, "RunOutcome | None", "BaseException | None"]


class Executor(Protocol):
    name: str
    capacity: int

    def submit(self, task: RunTask) -> Any: ...
    def wait(self, timeout: float) -> list[Completion]: ...
    def cancel(self) -> None: ...
    def close(self) -> None: ...


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class LocalExecutor:
    """A spawn-context process pool of ``workers`` processes."""

    name = "local"

    def __init__(self, workers: int):
        self.capacity = max(1, int(workers))
        self._ctx = multiprocessing.get_context("spawn")
        self._pool = self._new_pool()
        self._futures: set[cf.Future] = set()
        self._broken = False

    def _new_pool(self) -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(max_workers=self.capacity, mp_context=self._ctx, initializer=init_worker)

    def submit(self, task: RunTask) -> cf.Future:
        if self._broken:
            # a worker died hard (killed, out of memory): the pool is unusable, start a fresh one
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = self._new_pool()
            self._broken = False
        fut = self._pool.submit(execute, task)
        self._futures.add(fut)
        return fut

    def wait(self, timeout: float) -> list[Completion]:
        if not self._futures:
            return []
        done, _ = cf.wait(self._futures, timeout=timeout, return_when=cf.FIRST_COMPLETED)
        out: list[Completion] = []
        for fut in done:
            self._futures.discard(fut)
            if fut.cancelled():
                out.append((fut, None, cf.CancelledError()))
                continue
            exc = fut.exception()
            if isinstance(exc, BrokenProcessPool):
                self._broken = True
            out.append((fut, None if exc else fut.result(), exc))
        return out

    def cancel(self) -> None:
        for fut in self._futures:
            fut.cancel()
        # ProcessPoolExecutor has no public way to stop a running task (3.14 adds
        # terminate_workers); its worker processes are terminated directly.
        for proc in list(getattr(self._pool, "_processes", {}).values()):
            if proc.is_alive():
                proc.terminate()
        self._pool.shutdown(wait=True, cancel_futures=True)
        self._futures.clear()

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


#: dask's setting of the environment its nanny gives the worker processes it spawns.
NANNY_ENV = "distributed.nanny.pre-spawn-environ"


def nanny_environ() -> dict[str, Any]:
    """dask's pre-spawn environment for our LocalCluster's workers, less ``MALLOC_TRIM_THRESHOLD_``.

    dask sets it (to 65536) so that a worker hands freed memory back to the OS at once. A campaign
    run's memory is small and steady, and the trimming made every run pay: 45-day runs in one
    process with and without it (three processes each, two runs each, quiet machine) took
    4.74-5.10 s CPU against 4.60-4.91 s, ~4.5 % more."""
    import dask

    environ = dict(dask.config.get(NANNY_ENV, default={}) or {})
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    return environ


class DaskExecutor:
    """A dask.distributed client: on ``scheduler`` if given, else on a loopback LocalCluster."""

    name = "dask"

    def __init__(self, workers: int, scheduler: str | None = None, connect_timeout_s: float = 30.0):
        try:
            import distributed
        except ImportError:  # optional dependency: pip install navbank[dask]
            raise RuntimeError("the dask executor needs the 'distributed' package (pip install navbank[dask])") from None
        self._dist = distributed
        self.cluster = None
        if scheduler:
            self.client = distributed.Client(scheduler, timeout=connect_timeout_s)
        else:
            import dask

            # the scheduler, the nannies and the workers wake their event loops less often
            with dask.config.set({NANNY_ENV: nanny_environ(), **quiet_settings()}):
                self.cluster = distributed.LocalCluster(
                    n_workers=max(1, int(workers)), threads_per_worker=1, processes=True, host="127.0.0.1",
                    dashboard_address=None, silence_logs=logging.ERROR, preload=["tools.campaign.warm"],
                )
            self.client = distributed.Client(self.cluster, timeout=connect_timeout_s)
        nthreads = self.client.nthreads()
        self.capacity = max(1, sum(nthreads.values())) if nthreads else max(1, int(workers))
        self._futures: set = set()

    def submit(self, task: RunTask) -> Any:
        key = f"navbank-run-{task.id}-{uuid.uuid4().hex[:8]}"
        fut = self.client.submit(execute, task, key=key, pure=False, retries=0)
        self._futures.add(fut)
        return fut

    def wait(self, timeout: float) -> list[Completion]:
        if not self._futures:
            return []
        try:
            done, _ = self._dist.wait(list(self._futures), timeout=timeout, return_when="FIRST_COMPLETED")
        except TimeoutError:  # asyncio's and the builtin are one class since Python 3.11
            return []
        out: list[Completion] = []
        for fut in done:
            self._futures.discard(fut)
            if fut.status == "finished":
                out.append((fut, fut.result(), None))
            elif fut.status == "cancelled":
                out.append((fut, None, cf.CancelledError()))
            else:
                try:
                    exc = fut.exception()
                except Exception as err:  # the scheduler lost the task
                    exc = err
                out.append((fut, None, exc))
        return out

    def cancel(self) -> None:
        if self._futures:
            self.client.cancel(list(self._futures), force=True)
        self._futures.clear()

    def close(self) -> None:
        try:
            self.client.close()
        finally:
            if self.cluster is not None:
                self.cluster.close()


def make_executor(kind: str, workers: int | None, scheduler: str | None = None) -> Executor:
    n = workers or os.cpu_count() or 1
    if kind == "local":
        return LocalExecutor(n)
    if kind == "dask":
        return DaskExecutor(n, scheduler)
    raise ValueError(f"unknown executor {kind!r}; known: local, dask")

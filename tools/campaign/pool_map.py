"""A parallel ``map`` over the campaign executors' workers, for work that is one function over
many inputs rather than campaign runs (the GA's per-generation bank re-processing).

``local`` uses a spawn-context process pool (never fork, for the reasons in
:mod:`tools.campaign.executors`; workers ignore SIGINT); ``dask`` maps on a
``distributed.Client`` — on ``scheduler`` if given, else a loopback LocalCluster. One worker and
no scheduler maps in this process.
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import multiprocessing
from types import TracebackType
from typing import Any, Callable, Iterable, Iterator

from tools.campaign.executors import _ignore_sigint


class PoolMap:
    """Context manager; the instance is callable like ``map(fn, *iterables)`` (results in order)."""

    def __init__(self, kind: str = "local", workers: int = 1, scheduler: str | None = None):
        if kind not in ("local", "dask"):
            raise ValueError(f"unknown executor {kind!r}; known: local, dask")
        self.kind = "dask" if scheduler else kind
        self.workers = max(1, int(workers))
        self.scheduler = scheduler
        self._pool: cf.ProcessPoolExecutor | None = None
        self._client: Any = None
        self._cluster: Any = None

    def __enter__(self) -> "PoolMap":
        if self.kind == "dask":
            try:
                import distributed
            except ImportError:
                raise RuntimeError("the dask executor needs the 'distributed' package (pip install navbank[dask])") from None
            if self.scheduler:
                self._client = distributed.Client(self.scheduler, timeout=30)
            else:
                self._cluster = distributed.LocalCluster(
                    n_workers=self.workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                    dashboard_address=None, silence_logs=logging.ERROR)
                self._client = distributed.Client(self._cluster, timeout=30)
        elif self.workers > 1:
            self._pool = cf.ProcessPoolExecutor(max_workers=self.workers, initializer=_ignore_sigint,
                                                mp_context=multiprocessing.get_context("spawn"))
        return self

    @property
    def chunks(self) -> int:
        """How many pieces to split one job into so every worker has one."""
        if self._client is not None:
            return max(1, sum(self._client.nthreads().values()))
        return self.workers

    def __call__(self, fn: Callable[..., Any], *iterables: Iterable[Any]) -> Iterator[Any]:
        if self._client is not None:
            return iter(self._client.gather(self._client.map(fn, *iterables, pure=False)))
        if self._pool is not None:
            return self._pool.map(fn, *iterables)
        return map(fn, *iterables)

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()

"""Warming a campaign worker process before its first run.

A worker (a spawned pool process, a ``dask worker``) lives for many runs, so what is paid once
per process — imports of the FSW, simulator and report code, loading compiled kernels from their
on-disk cache — belongs to its start, not to the first run it gets. Importing this module does
it (``dask worker --preload tools.campaign.warm``); :func:`init_worker` is the local pool's
initializer.
"""

from __future__ import annotations

import signal

import tools.campaign.worker  # noqa: F401  (the run code and everything it imports)


def init_worker() -> None:
    """Local pool worker start: ignore SIGINT (the campaign runner decides about Ctrl-C); the
    imports are done by importing this module."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


__all__ = ["init_worker"]

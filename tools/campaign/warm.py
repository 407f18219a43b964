"""Warming a campaign worker process before its first run.

A worker (a spawned pool process, a ``dask worker``) lives for many runs, so what is paid once
per process belongs to its start, not to the first run it gets: imports of the FSW, simulator
and report code (importing this module does them, ~1 s CPU), and whatever the flight code sets
up on first use — tables loaded lazily, compiled kernels loaded from their on-disk cache (or
compiled when it is cold). :func:`warm_up` flies a few hours of the default scenario in
process for the latter, so that no run's first frames are charged for it.

Hooks: the local pool's initializer is :func:`init_worker`; dask calls :func:`dask_setup` of a
preloaded module (``dask worker --preload tools.campaign.warm``; the ``LocalCluster`` of
:mod:`tools.campaign.executors` preloads it too). Importing the module alone flies nothing.
"""

from __future__ import annotations

import dataclasses
import signal
from typing import Any

import tools.campaign.worker  # noqa: F401  (the run code and everything it imports)

#: Length of the warm-up flight: long enough to exercise every measurement kind and stage.
WARM_UP_DAYS = 0.25


def warm_up() -> None:
    """Fly a short nominal arc of the default scenario in this process and drop the result."""
    from tools.inprocess import run_in_process
    from tools.scenario import load_scenario

    cfg = load_scenario("insight-approach")
    sim = dataclasses.replace(cfg.sim, faults=(),
                              trajectory=dataclasses.replace(cfg.sim.trajectory, span_days=WARM_UP_DAYS))
    run_in_process(dataclasses.replace(cfg, sim=sim), 1, run_id="warm-up")


def init_worker() -> None:
    """Local pool worker start: ignore SIGINT (the campaign runner decides about Ctrl-C), warm up."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    warm_up()


def dask_setup(worker: Any) -> None:
    """dask's preload hook: warm the worker process up once, at its start."""
    warm_up()


__all__ = ["init_worker", "dask_setup", "warm_up", "WARM_UP_DAYS"]

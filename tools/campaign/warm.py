"""Warming a campaign worker process before its first run.

A worker (a spawned pool process, a ``dask worker``) lives for many runs, so what is paid once
per process belongs to its start, not to the first run it gets: imports of the FSW, simulator
and report code (importing this module does them, ~1 s CPU), and whatever the flight code sets
up on first use — tables loaded lazily, compiled kernels loaded from their on-disk cache (or
compiled when it is cold). :func:`warm_up` flies a few hours of the default scenario in
process for the latter, so that no run's first frames are charged for it.

Hooks: the local pool's initializer is :func:`init_worker`; dask calls :func:`dask_setup` of a
preloaded module (``dask worker --preload tools.campaign.warm``; the ``LocalCluster`` of
:mod:`tools.campaign.executors` preloads it too), which also keeps dask's statistical profiler
off the worker (:func:`stop_profiler`) and wakes its event loop less often
(:func:`quieten_event_loop`). Importing the module alone flies nothing.
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


#: The periodic callbacks of dask's statistical profiler on a worker.
PROFILER_CALLBACKS = ("profile", "profile-cycle")


def stop_profiler(worker: Any) -> None:
    """Keep dask's statistical profiler off this worker: every 10 ms it takes the GIL from the
    task thread to sample its stack, and a campaign run is pure Python, so it cost the runs
    ~10 % of a worker's rate (12-day runs on one LocalCluster worker, other load stopped: 30.9
    and 36.5 runs/min with it, 38.7 and 41.1 without; the local pool 37.9 and 41.3). Called
    from the preload hook, before the worker starts its periodic callbacks: removed, they never
    start."""
    for key in PROFILER_CALLBACKS:
        callback = worker.periodic_callbacks.pop(key, None)
        if callback is not None:
            callback.stop()


#: dask's event-loop callbacks that a campaign needs less often: callback name -> (the dask
#: setting of its period, the period in ms it gets). The check that the loop is not blocked (20 ms
#: by default; it warns after 3 s of blocking, which a 1 s period still sees), the system monitor
#: that feeds the dashboard's CPU and memory plots (500 ms), and the memory monitor that spills,
#: pauses or (a nanny's) restarts a worker near its memory limit (100 ms; a run's memory grows
#: by tens of MB per second at most).
QUIET_CALLBACKS: dict[str, tuple[str, float]] = {
    "tick": ("distributed.admin.tick.interval", 1000.0),
    "monitor": ("distributed.admin.system-monitor.interval", 5000.0),
    "memory_monitor": ("distributed.worker.memory.monitor-interval", 1000.0),
}


def quiet_settings() -> dict[str, str]:
    """The dask settings of :data:`QUIET_CALLBACKS`, for a cluster started here (its scheduler,
    nannies and workers all take them)."""
    return {key: f"{period_ms:g}ms" for key, period_ms in QUIET_CALLBACKS.values()}


def quieten_event_loop(worker: Any) -> None:
    """Wake a worker's event loop less often while a task runs (:data:`QUIET_CALLBACKS`), on a
    worker started elsewhere (``dask worker --preload tools.campaign.warm``) as on ours.

    Every wake takes the GIL from the task thread (a run is pure Python) and costs it a thread
    switch and cold caches; a LocalCluster worker's event loop woke ~140 times a second with the
    defaults. 45-day runs on a 2-worker LocalCluster, three each, alternating, other load
    stopped: 4.33-4.72 s CPU each at 24.0-26.4 runs/min with dask's defaults, 4.32-4.39 s at
    26.8-27.0 runs/min with these periods (and the same settings for the cluster, below). Periods
    are only lengthened, never shortened (a worker configured quieter stays so)."""
    for key, (_, period_ms) in QUIET_CALLBACKS.items():
        callback = worker.periodic_callbacks.get(key)
        if callback is not None and callback.callback_time < period_ms:
            callback.callback_time = period_ms


def dask_setup(worker: Any) -> None:
    """dask's preload hook: no statistical profiler, a quieter event loop, and the worker process
    warmed up once, at its start."""
    stop_profiler(worker)
    quieten_event_loop(worker)
    warm_up()


__all__ = ["init_worker", "dask_setup", "quiet_settings", "quieten_event_loop", "stop_profiler", "warm_up",
           "WARM_UP_DAYS", "PROFILER_CALLBACKS", "QUIET_CALLBACKS"]

"""One run with the simulator and the FSW wired directly, without Zenoh (campaigns, tests, replay).

It runs exactly the code the processes run — ``sim.stream.generate`` for the simulator and
``fsw.core.FswCore`` for the flight software — so in deterministic (work-unit) budget mode its
FSW outputs are identical to those of ``navbank run`` for the same scenario, fault and seed.
"""

from __future__ import annotations

import gc
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Callable, Iterator

from fsw.core import FswCore, stamp
from fsw.core.pipeline import no_gc_pauses
from fsw.interface import messages as m, topics
from sim.stream import SimRun, generate
from tools.scenario import ScenarioConfig, resolve
from ground.report.run_summary import summarize
from ground.report.summary_types import RunSummary


@dataclass(frozen=True)
class RunTimings:
    """Where one in-process run's time went: CPU seconds of this process per phase, and the wall."""

    resolve_cpu_s: float  # the scenario's initial state
    sim_cpu_s: float  # the simulator's stream
    fsw_cpu_s: float  # the FSW core: start, every measurement, finish
    summary_cpu_s: float  # the run summary
    wall_s: float


@dataclass
class RunResult:
    """Everything one in-process run produced: the ``(topic, message)`` pairs in the order the
    simulator and the FSW emitted them, and the run's summary."""

    config: ScenarioConfig
    seed: int
    messages: list[tuple[str, Any]]
    summary: RunSummary
    sim: SimRun | None = None
    timings: RunTimings | None = None

    def topic(self, name: str) -> list[Any]:
        name = name.strip("/")
        return [msg for t, msg in self.messages if t == name]


@contextmanager
def collector_held() -> Iterator[None]:
    """Python's cyclic garbage collector held off for a run (or a campaign task), and the garbage
    it left freed at the end by one collection of the youngest generation.

    A run keeps every message it makes, so the full passes that growth triggers re-scan all of
    them again and again (measured 1.1 s of a 6.4 s CPU default run), and a campaign task that
    then reads weight histories out of the messages triggered 0.6-0.7 s of collections in a
    6 s detection-matrix task. A run leaves only a few thousand cyclic objects (3,895 measured).
    Held off, nothing the run made has left the youngest generation, so collecting that one
    frees them; a full collection would also re-scan every object the process had before (its
    imports: 0.3 s of a 5.5 s CPU 45-day run). Nested holds leave the collection to the
    outermost one."""
    if not gc.isenabled():
        yield
        return
    try:
        with no_gc_pauses():
            yield
    finally:
        gc.collect(0)


class _Recorder:
    """The FSW core's sink: appends to the run's message list until closed.

    The core lives in reference cycles (its pipeline stages are its own bound methods), so it is
    freed only by the cyclic collector; closed, its sink no longer keeps the run's ~10^5 messages
    alive with it. They go when the caller drops the result, not at a collection that would have
    to traverse all of them (0.3-0.45 s measured at the end of a 45-day campaign task)."""

    __slots__ = ("out",)

    def __init__(self, out: list[tuple[str, Any]]):
        self.out: list[tuple[str, Any]] | None = out

    def __call__(self, topic: str, msg: Any) -> None:
        if self.out is not None:
            self.out.append((topic, msg))

    def close(self) -> None:
        self.out = None


def sim_status(run: SimRun, run_id: str, state: m.RunState) -> m.RunStatus:
    t = run.t_end if state == "end-of-run" else run.t_start
    return m.RunStatus(t_s=t, timestamp=stamp(t), run_id=run_id, source="sim", state=state,
                       counts={"measurements": len(run.measurements), "truth": len(run.truth),
                               "fault_events": len(run.fault_events)})


def run_in_process(cfg: ScenarioConfig, seed: int | None = None, *, fault_label: str | None = None,
                   run_id: str = "inprocess", progress: Callable[[float], None] | None = None,
                   keep_sim: bool = False) -> RunResult:
    """Simulate and fly one run in this process; returns all messages and the summary."""
    with collector_held():
        return _run(cfg, seed, fault_label=fault_label, run_id=run_id, progress=progress, keep_sim=keep_sim)


def _run(cfg: ScenarioConfig, seed: int | None, *, fault_label: str | None, run_id: str,
         progress: Callable[[float], None] | None, keep_sim: bool) -> RunResult:
    wall0 = time.perf_counter()
    c0 = time.process_time()
    resolved, seed = resolve(cfg, seed)
    c1 = time.process_time()
    run = generate(resolved.sim, seed=seed)
    c2 = time.process_time()
    out: list[tuple[str, Any]] = []
    sink = _Recorder(out)
    core = FswCore(resolved.fsw, sink, run_id=run_id)
    out.append((topics.SIM_STATUS, sim_status(run, run_id, "start")))
    core.start()
    n = max(len(run.measurements), 1)
    done = 0
    for topic, msg in run.iter_messages():
        out.append((topic, msg))
        if isinstance(msg, m.Measurement):
            core.ingest(msg)
            done += 1
            if progress is not None and done % 500 == 0:
                progress(done / n)
    out.append((topics.SIM_STATUS, sim_status(run, run_id, "end-of-run")))
    core.finish()
    sink.close()
    c3 = time.process_time()
    if progress is not None:
        progress(1.0)
    summary = summarize(out, scenario=resolved.name, seed=seed, fault=fault_label, t0=run.t_start,
                        wall_time_s=time.perf_counter() - wall0)
    timings = RunTimings(resolve_cpu_s=c1 - c0, sim_cpu_s=c2 - c1, fsw_cpu_s=c3 - c2,
                         summary_cpu_s=time.process_time() - c3, wall_s=time.perf_counter() - wall0)
    return RunResult(config=resolved, seed=seed, messages=out, summary=summary, sim=run if keep_sim else None,
                     timings=timings)

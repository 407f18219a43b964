"""FSW-core rows of ``navbank bench``: the default scenario flown in this process.

* ``fsw-core-cpu``: CPU µs of the FSW core (:class:`fsw.core.FswCore`: start, every measurement,
  finish) per measurement of the default scenario (``insight-approach``, seed 1), against the
  goal figure of 60 µs: ratio = 60 µs / ours, met when ≥ 1. Its details say where that CPU goes:
  ``stage_us_per_measurement`` per stage label as the frame executive measured it (the FSW's
  end-of-run status carries it), ``outside_stages_us_per_measurement`` the rest (intake,
  frames, executive bookkeeping between stages, per-frame telemetry), and
  ``bank_alone_us_per_measurement`` the filter bank's ``process`` over the same run's
  measurements with nothing in between (:func:`bank_alone_us`): set against the bank stage
  (which also makes the hourly estimates), what running among the other stages costs the same
  code.
* ``fsw-core-flop-rate``: the bank's dense Kalman arithmetic per measurement
  (:func:`kalman_flops`) over that CPU time, against the rate numpy reaches on batched n × n
  matmuls of the bank's size measured just before: ratio = achieved / matmul rate, goal ≥ 20 %.
* ``inprocess-45day-wall``: wall time of one whole in-process run (simulator, FSW, summary)
  of the 45-day scenario, against the goal figure of 3 s: ratio = 3 s / ours.
* ``budget-overruns``: overruns the frame executive reported at the scenario's nominal budget,
  start-up frames included; goal 0 (the reference column is the frames run).

``quick`` flies a shorter arc of the same scenario (faults after its end dropped); the 45-day
wall is then the short run's wall scaled by the measurement count, and the row says so.
The machine may be shared: CPU time is what the per-measurement rows use; medians of repeats.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from dataclasses import dataclass
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from fsw.core.counters import stage_cpu_by_label
from fsw.core.pipeline import no_gc_pauses
from fsw.filters.bank import FilterBank
from fsw.filters.ekf import union_layout
from fsw.filters.errors import MeasurementRejected
from fsw.interface import topics
from tools.bench.rows import Goal, make_row
from tools.inprocess import RunResult, run_in_process
from tools.scenario import ScenarioConfig, load_scenario, resolve

DEFAULT_SCENARIO = "insight-approach"
CORE_GOAL_US = 60.0
INPROCESS_GOAL_S = 3.0
CORE_GOAL = Goal("cost", ">=", 1.0)
FLOP_GOAL = Goal("rate", ">=", 0.20)
WALL_GOAL = Goal("cost", ">=", 1.0)
OVERRUN_GOAL = Goal("rate", "<=", 0.0, on="ours", unit="overruns")


def scenario(span_days: float | None = None, name: str = DEFAULT_SCENARIO) -> ScenarioConfig:
    """The default scenario, optionally over its first ``span_days`` (faults starting later dropped)."""
    cfg = load_scenario(name)
    if span_days is None or span_days >= cfg.sim.trajectory.span_days:
        return cfg
    faults = tuple(f for f in cfg.sim.faults if f.onset_day < span_days)
    sim = dataclasses.replace(cfg.sim, trajectory=dataclasses.replace(cfg.sim.trajectory, span_days=span_days),
                              faults=faults)
    return dataclasses.replace(cfg, sim=sim)


def kalman_flops(filters: int, states: int, measurement_dim: int = 1) -> float:
    """Floating-point operations of one measurement's dense Kalman arithmetic in a bank.

    Per filter: the covariance time update ΦPΦᵀ (two n × n products, 4n³) and the Joseph
    measurement update (I − KH)P(I − KH)ᵀ + KRKᵀ (4n³ + 4n²m), with the gain PHᵀS⁻¹ and
    HPHᵀ (2n²m + 2nm²). The orbit propagation and the measurement models are left out, so the
    achieved rate computed from it is a lower bound.
    """
    n, m = states, measurement_dim
    return float(filters * (8 * n**3 + 6 * n**2 * m + 2 * n * m**2))


def matmul_rate(batch: int, n: int, seconds: float = 0.3) -> float:
    """FLOP/s numpy reaches on batched (batch, n, n) @ (batch, n, n) here and now (best of repeats)."""
    rng = np.random.default_rng(0)
    A, B = rng.standard_normal((batch, n, n)), rng.standard_normal((batch, n, n))
    C = np.empty_like(A)
    number = 200
    best = float("inf")
    deadline = time.perf_counter() + seconds
    while True:
        t0 = time.perf_counter()
        for _ in range(number):
            np.matmul(A, B, out=C)
        best = min(best, (time.perf_counter() - t0) / number)
        if time.perf_counter() > deadline:
            break
    return 2.0 * n**3 * batch / best


@dataclass(frozen=True)
class InProcessFigures:
    """Medians over repeats of one in-process run's figures."""

    span_days: float
    measurements: int
    filters: int
    states: int
    fsw_cpu_s: float
    sim_cpu_s: float
    run_cpu_s: float  # the whole run_in_process call: resolve, simulator, FSW core, summary
    wall_s: float
    overruns: int
    frames: int
    max_utilisation: float
    budget_mode: str | None
    repeats: int
    #: CPU the executive measured inside the core's stages (mode cpu; None otherwise): the part of
    #: ``fsw_cpu_s`` spent in the stages themselves rather than between them
    stage_cpu_s: float | None = None
    #: the same per stage label, µs per measurement (the end-of-run status's counts; medians per
    #: label): where the core's CPU goes, stage by stage
    stage_us: dict[str, float] | None = None
    #: CPU µs per measurement of the filter bank alone over the same measurements (:func:`bank_alone_us`)
    bank_alone_us: float | None = None


def stage_cpu_s(reports: Iterable[Any], cpu_scale: float) -> float | None:
    """CPU seconds the FSW's stages used, from its BudgetReports (ICD messages or their JSON
    dicts): every frame that runs a stage is reported, and in mode ``cpu`` a report's ``used`` is
    its stages' measured thread CPU times ``cpu_scale``. None if the reports are of another mode
    (work units say nothing about CPU) or there are none."""
    total, seen = 0.0, False
    for rep in reports:
        mode, used = (rep["mode"], rep["used"]) if isinstance(rep, dict) else (rep.mode, rep.used)
        if mode != "cpu":
            return None
        total += used
        seen = True
    return total / cpu_scale if seen else None


def stage_us_per_measurement(statuses: Sequence[Any], measurements: int) -> dict[str, float]:
    """CPU µs per measurement of each stage label, from the last of a run's FSW ``RunStatus``
    messages (ICD objects or their JSON dicts); empty if it measured none (mode work-units)."""
    if not statuses or measurements <= 0:
        return {}
    last = statuses[-1]
    counts = last["counts"] if isinstance(last, dict) else last.counts
    return {label: cpu / measurements * 1e6 for label, cpu in stage_cpu_by_label(counts).items()}


def bank_alone_us(result: RunResult, seed: int) -> float | None:
    """CPU µs per measurement of a fresh filter bank of the run's configuration processing the
    run's measurements one after the other, nothing else in between (the garbage collector held,
    as in the core's frames); None for a bank other than the onboard EKF bank.

    The same code as the core's bank stage, but alone: on the default scenario it took ~42 µs a
    measurement against ~52 µs for the same calls inside the core, where the gating, the
    executive and the telemetry run between them. No single function's profile shows that
    difference; the caches do: alone, with 2 MB of other data read between two measurements the
    bank took 64-68 µs, with 128 KB 43-46 µs (the bank's compiled Doppler step alone is 166 kB of
    machine code). None also for a run without measurements."""
    resolved, _ = resolve(result.config, seed)
    init = resolved.fsw.initial_state
    measurements = result.topic(topics.SIM_MEASUREMENTS)
    if resolved.fsw.central_body != "mars" or init is None or not measurements:
        return None
    bank = FilterBank(resolved.fsw.bank, init.t_s, init.position_km, init.velocity_km_s)
    with no_gc_pauses():
        c0 = time.thread_time()
        for meas in measurements:
            try:
                bank.process(meas)
            except MeasurementRejected:
                pass
        cpu = time.thread_time() - c0
    return cpu / len(measurements) * 1e6


def fly(span_days: float | None = None, repeats: int = 3, seed: int = 1) -> InProcessFigures:
    """Fly the default scenario ``repeats`` times in this process; medians of the timings, the
    worst overrun count."""
    cfg = scenario(span_days)
    results: list[RunResult] = []
    for _ in range(max(1, repeats)):
        results.append(run_in_process(cfg, seed))
    timings = [r.timings for r in results if r.timings is not None]
    last = results[-1]
    stages = [stage_cpu_s(r.topic(topics.FSW_BUDGET), r.config.fsw.budget.cpu_scale) for r in results]
    by_label = [stage_us_per_measurement(r.topic(topics.FSW_STATUS), r.summary.measurements.published)
                for r in results]
    n = last.summary.measurements.published
    bank_cfg = last.config.fsw.bank
    return InProcessFigures(
        span_days=cfg.sim.trajectory.span_days, measurements=max(n, 1), filters=len(last.summary.filters),
        states=union_layout(bank_cfg.filters).n,
        fsw_cpu_s=statistics.median(t.fsw_cpu_s for t in timings),
        sim_cpu_s=statistics.median(t.sim_cpu_s for t in timings),
        run_cpu_s=statistics.median(t.resolve_cpu_s + t.sim_cpu_s + t.fsw_cpu_s + t.summary_cpu_s for t in timings),
        wall_s=statistics.median(t.wall_s for t in timings),
        overruns=max(r.summary.budget.overruns for r in results),
        frames=last.summary.budget.frames, max_utilisation=last.summary.budget.max_utilisation,
        budget_mode=last.summary.budget.mode, repeats=len(results),
        stage_cpu_s=None if None in stages else statistics.median(stages),  # type: ignore[type-var]
        stage_us=None if not all(by_label) else {label: statistics.median(b[label] for b in by_label)
                                                  for label in by_label[0] if all(label in b for b in by_label)},
        bank_alone_us=bank_alone_us(last, seed),
    )


def _rounded(values: dict[str, float] | None) -> dict[str, float] | None:
    return None if values is None else {k: round(v, 1) for k, v in values.items()}


def core_rows(fig: InProcessFigures, full_measurements: int | None = None) -> list[dict[str, Any]]:
    """The four rows of this module from one set of figures. ``full_measurements``: the 45-day
    run's measurement count when ``fig`` is of a shorter arc (its wall is then scaled)."""
    us = fig.fsw_cpu_s / fig.measurements * 1e6
    flops = kalman_flops(fig.filters, fig.states)
    achieved = flops * fig.measurements / fig.fsw_cpu_s if fig.fsw_cpu_s > 0 else 0.0
    ref_rate = matmul_rate(fig.filters, fig.states)
    common = {"scenario": DEFAULT_SCENARIO, "span_days": fig.span_days, "measurements": fig.measurements,
              "repeats": fig.repeats}
    rows = [
        make_row("fsw-core-cpu", us, CORE_GOAL_US, "us CPU/measurement", CORE_GOAL,
                 "goal figure 60 us / ours (>= 1 meets FSW core <= 60 us CPU per measurement)",
                 matmul_floor_us=flops / ref_rate * 1e6, sim_cpu_s=fig.sim_cpu_s, fsw_cpu_s=fig.fsw_cpu_s,
                 stage_cpu_s=fig.stage_cpu_s, stage_us_per_measurement=_rounded(fig.stage_us),
                 outside_stages_us_per_measurement=(None if not fig.stage_us
                                                    else round(us - sum(fig.stage_us.values()), 1)),
                 bank_alone_us_per_measurement=None if fig.bank_alone_us is None else round(fig.bank_alone_us, 1),
                 **common),
        make_row("fsw-core-flop-rate", achieved / 1e9, ref_rate / 1e9, "GFLOP/s", FLOP_GOAL,
                 "achieved / numpy batched-matmul rate at the bank's size (share of the matmul rate)",
                 flop_per_measurement=flops, filters=fig.filters, states=fig.states, **common),
    ]
    if full_measurements and full_measurements != fig.measurements:
        wall = fig.wall_s * full_measurements / fig.measurements
        rows.append(make_row("inprocess-45day-wall", wall, INPROCESS_GOAL_S, "s wall", WALL_GOAL,
                             "goal figure 3 s / ours (>= 1 meets a 45-day in-process run <= 3 s)",
                             extrapolated_from_measurements=fig.measurements, measured_wall_s=fig.wall_s,
                             full_measurements=full_measurements, **common))
    else:
        rows.append(make_row("inprocess-45day-wall", fig.wall_s, INPROCESS_GOAL_S, "s wall", WALL_GOAL,
                             "goal figure 3 s / ours (>= 1 meets a 45-day in-process run <= 3 s)", **common))
    rows.append(make_row("budget-overruns", fig.overruns, fig.frames, "overruns", OVERRUN_GOAL,
                         "overruns at the nominal budget incl. start-up (reference: frames run)",
                         budget_mode=fig.budget_mode, max_utilisation=fig.max_utilisation, **common))
    return rows


#: Measurements of the default scenario's 45-day run (seed 1), to scale a quick run's wall to it
#: (a figure, not a measurement: simulating the 45 days only to count them would cost a second).
FULL_RUN_MEASUREMENTS = 29148


__all__ = ["InProcessFigures", "bank_alone_us", "fly", "core_rows", "kalman_flops", "matmul_rate", "scenario", "stage_cpu_s",
           "stage_us_per_measurement",
           "FULL_RUN_MEASUREMENTS"]

"""``navbank bench``: one row per speed goal, each against a reference measured in the same run.

Rows (every one: ``name``, ``ours``, ``reference``, ``unit``, ``ratio``, ``goal``, ``met``,
``meaning``, details and ``machine``, what it ran on (:mod:`.machine`); :mod:`tools.bench.rows`):

* :mod:`.core` — ``fsw-core-cpu`` (FSW core CPU per measurement, default scenario),
  ``fsw-core-flop-rate`` (its arithmetic's rate / numpy batched-matmul rate),
  ``inprocess-45day-wall`` (a whole 45-day in-process run, simulator included),
  ``budget-overruns`` (at the nominal budget, start-up included);
* :mod:`.decode` — ``icd-decode`` (strict ICD decoding of the stream's measurements vs ``json.loads``);
* :mod:`.filters` — ``linear-bank-vs-filterpy``, ``ekf-update-vs-filterpy-N3``/``-N6`` (FilterPy
  ``KalmanFilter`` / ``ExtendedKalmanFilter``) and, not with ``quick``, ``ekf-bank-stacking-3``/``-6``
  (the stacked EKF bank vs the same filters one by one);
* :mod:`.campaigns` — ``campaign-*``: runs/min on 1 and 2 workers on the local pool, a dask
  LocalCluster and a dask scheduler with worker processes;
* :mod:`.navrun` — ``navbank-run-wall``, ``navbank-run-fsw-cpu`` (``full`` only: starts ``navbank run``);
* :mod:`.steadiness` — ``machine-steadiness``, last: one fixed workload timed before each group
  and at the end, slowest / fastest (≤ 1.1: the machine kept its speed through the run).

``quick`` flies a 2-day arc of the default scenario instead of 45 days (walls are scaled to the
45-day run by measurement count and say so), runs campaigns of 2-day runs, one repeat each; it
is a rough figure in about a minute. ``full`` adds the rows that start ``navbank run`` (always
on the whole 45-day scenario).
"""

from __future__ import annotations

import json as _json
import sys
from collections.abc import Callable
from typing import IO, Any

from tools.bench.machine import machine
from tools.bench.rows import text_line
from tools.bench.steadiness import Steadiness

QUICK_SPAN_DAYS = 2.0


def run_benchmarks(json: bool = False, quick: bool = False, full: bool = False, out: IO[str] | None = None,
                   only: Callable[[str], bool] | None = None) -> list[dict[str, Any]]:
    """Run the benchmarks and print their rows (text, or one JSON object per line).

    ``only(group)`` selects groups (``filters``, ``decode``, ``core``, ``campaigns``, ``navrun``)."""
    from fsw.filters.presets import preset
    from fsw.models.environment import Environment
    from tools.bench import core, decode, filters

    out = out if out is not None else sys.stdout
    rows: list[dict[str, Any]] = []
    want = only or (lambda group: True)
    emit = _printer(rows, json, out)

    def note(text: str) -> None:
        print(text, file=sys.stderr if json else out, flush=True)

    steadiness = Steadiness()  # the probe before each group of rows and at the end

    if want("filters"):
        steadiness.sample("filters")
        try:
            import filterpy.kalman  # noqa: F401  (the reference of the FilterPy rows)
        except ImportError:
            note("linear-bank-vs-filterpy, ekf-update-vs-filterpy skipped: their reference, FilterPy, is not "
                 "installed (pip install \"navbank[bench]\" or pip install filterpy)")
        else:
            env = Environment()
            emit(filters.bench_linear(number=100 if quick else 400, repeat=5 if quick else 15))
            emit(filters.bench_ekf_filterpy(preset("nominal"), "ekf-update-vs-filterpy-N3", env,
                                            number=100 if quick else 300, repeat=3 if quick else 7))
            emit(filters.bench_ekf_filterpy(preset("acs-q"), "ekf-update-vs-filterpy-N6", env,
                                            number=100 if quick else 300, repeat=3 if quick else 7))
        if not quick:
            env = Environment()
            stream = filters.insight_stream(600, env)
            emit(filters.bench_stacking(preset("nominal"), "ekf-bank-stacking-3", stream, env))
            emit(filters.bench_stacking(preset("acs-q"), "ekf-bank-stacking-6", stream, env))
    if want("decode"):
        steadiness.sample("decode")
        stream = filters.insight_stream(120 if quick else 600, Environment())
        emit(decode.bench_decode(seconds=0.5 if quick else 2.0, measurements=stream[3], label=stream[4]))
    span = QUICK_SPAN_DAYS if quick else None
    fig = None
    if want("core") or want("navrun") or want("campaigns"):
        steadiness.sample("core")
        fig = core.fly(span, repeats=1 if quick else 3)
    full_n = core.FULL_RUN_MEASUREMENTS if quick else None
    if fig is not None and want("core"):
        for row in core.core_rows(fig, full_measurements=full_n):
            emit(row)
    if want("campaigns"):
        from tools.bench.campaigns import campaign_rows

        assert fig is not None
        steadiness.sample("campaigns")
        for row in campaign_rows(fig.span_days, inprocess_cpu_s=fig.run_cpu_s,
                                 runs_per_worker=4 if quick else 3, repeats=1 if quick else 2):
            emit(row)
    if full and want("navrun"):
        from tools.bench.navrun import navrun_rows

        assert fig is not None
        steadiness.sample("navrun")
        # the reference is the 45-day in-process core: a shorter arc's CPU per measurement differs
        whole = fig if not quick else core.fly(None, repeats=1)
        stage_us = None if whole.stage_cpu_s is None else whole.stage_cpu_s / whole.measurements * 1e6
        for row in navrun_rows(core.scenario(), 1, whole.fsw_cpu_s / whole.measurements * 1e6, stage_us,
                               whole.stage_us):
            emit(row)
    steadiness.sample("end")
    emit(steadiness.row())
    return rows


def run_against(rev: str, json: bool = False, quick: bool = False, out: IO[str] | None = None) -> list[dict[str, Any]]:
    """``navbank bench --against REV``: the working tree's FSW core against ``rev``'s in lock step
    (:mod:`tools.bench.against`; a 2-day arc with ``quick``), then the steadiness row."""
    from tools.bench.against import compare

    out = out if out is not None else sys.stdout
    rows: list[dict[str, Any]] = []
    emit = _printer(rows, json, out)
    steadiness = Steadiness()
    steadiness.sample("against")
    emit(compare(rev, span_days=QUICK_SPAN_DAYS if quick else None, repeats=2 if quick else 5,
                 progress=sys.stderr if json else out))
    steadiness.sample("end")
    emit(steadiness.row())
    return rows


def _printer(rows: list[dict[str, Any]], json: bool, out: IO[str]) -> Callable[[dict[str, Any]], None]:
    """What prints a row (text, or one JSON object per line) and keeps it in ``rows``; the text
    output starts with the machine, which every row carries."""
    host = machine()
    if not json:  # JSON rows carry it themselves
        print("machine: " + ", ".join(f"{key} {value}" for key, value in host.items()), file=out, flush=True)

    def emit(row: dict[str, Any]) -> None:
        row = {**row, "machine": host}
        rows.append(row)
        print(_json.dumps(row) if json else text_line(row), file=out, flush=True)

    return emit


__all__ = ["run_against", "run_benchmarks", "QUICK_SPAN_DAYS"]

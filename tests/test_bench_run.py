"""``navbank bench``: its rows (name, ours, reference, unit, ratio, goal, met) and their verdicts."""

from __future__ import annotations

import io
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from tools.bench import run_benchmarks
from tools.bench.core import InProcessFigures, core_rows, kalman_flops
from tools.bench.rows import Goal, make_row, skipped_row, text_line

ROW_KEYS = {"name", "ours", "reference", "unit", "ratio", "goal", "met", "meaning"}


def test_a_cost_goal_is_met_when_the_reference_takes_long_enough():
    g = Goal("cost", ">=", 10.0)
    row = make_row("x", 2.0, 30.0, "us", g, "ref / ours")
    assert row["ratio"] == 15.0 and row["met"] is True and row["goal"] == "ratio >= 10"
    assert make_row("x", 4.0, 30.0, "us", g, "")["met"] is False


def test_rate_gain_and_absolute_goals():
    assert make_row("fsw-cpu", 13.0, 10.0, "s", Goal("rate", "<=", 1.3), "")["met"] is True
    assert make_row("fsw-cpu", 13.1, 10.0, "s", Goal("rate", "<=", 1.3), "")["met"] is False
    gain = make_row("scaling", 18.6, 10.0, "runs/min", Goal("gain", ">=", 0.85), "")
    assert gain["ratio"] == pytest.approx(0.86) and gain["met"] is True
    assert make_row("scaling", 18.4, 10.0, "runs/min", Goal("gain", ">=", 0.85), "")["met"] is False
    # an absolute goal looks at ours, whatever the reference
    dec = make_row("decode", 90_000.0, 400_000.0, "msg/s", Goal("rate", ">=", 100_000.0, on="ours"), "")
    assert dec["ratio"] == pytest.approx(0.225) and dec["met"] is False
    over = Goal("rate", "<=", 0.0, on="ours")
    assert make_row("overruns", 0, 2800, "overruns", over, "")["met"] is True
    assert make_row("overruns", 1, 2800, "overruns", over, "")["met"] is False


def test_a_ratio_that_is_not_a_number_is_null_and_a_zero_measurement_is_never_met():
    nan = make_row("x", 0.0, 0.0, "us", Goal("cost", ">=", 1.0), "")
    assert nan["met"] is False and nan["ratio"] is None
    inf = make_row("x", 0.0, 1.0, "us", Goal("cost", ">=", 1.0), "")
    assert inf["ratio"] is None and inf["met"] is True  # no time at all beats any reference
    json.loads(json.dumps(nan, allow_nan=False))
    assert "ratio        -" in text_line(nan)


def test_rows_print_as_one_json_object_or_one_line():
    row = make_row("x", 2.0, 30.0, "us", Goal("cost", ">=", 10.0), "ref / ours", filters=3)
    assert ROW_KEYS <= set(json.loads(json.dumps(row))) and row["filters"] == 3
    line = text_line(row)
    assert line.startswith("x ") and "ratio" in line and "met" in line and "\n" not in line
    skipped = skipped_row("y", "us", Goal("cost", ">=", 1.0), "no /proc")
    assert skipped["met"] is False and "skipped: no /proc" in text_line(skipped)


def _figures(**changes) -> InProcessFigures:
    base = dict(span_days=2.0, measurements=1000, filters=3, states=16, fsw_cpu_s=0.5, sim_cpu_s=0.1, run_cpu_s=0.7, wall_s=0.8,
                overruns=0, frames=2000, max_utilisation=0.5, budget_mode="cpu", repeats=1)
    base.update(changes)
    return InProcessFigures(**base)  # type: ignore[arg-type]


def test_core_rows_from_fake_timings():
    rows = {r["name"]: r for r in core_rows(_figures(), full_measurements=29148)}
    assert list(rows) == ["fsw-core-cpu", "fsw-core-flop-rate", "inprocess-45day-wall", "budget-overruns"]
    core = rows["fsw-core-cpu"]
    assert core["ours"] == pytest.approx(500.0) and core["reference"] == 60.0 and core["met"] is False
    assert core["ratio"] == pytest.approx(0.12)
    flop = rows["fsw-core-flop-rate"]
    assert flop["ours"] == pytest.approx(kalman_flops(3, 16) * 1000 / 0.5 / 1e9)
    assert flop["reference"] > 0 and flop["ratio"] == pytest.approx(flop["ours"] / flop["reference"])
    wall = rows["inprocess-45day-wall"]  # a 2-day arc's wall scaled to the 45-day run's measurements
    assert wall["ours"] == pytest.approx(0.8 * 29.148) and wall["extrapolated_from_measurements"] == 1000
    assert rows["budget-overruns"]["met"] is True
    fast = {r["name"]: r for r in core_rows(_figures(fsw_cpu_s=0.05, wall_s=2.0, overruns=1))}
    assert fast["fsw-core-cpu"]["met"] is True and fast["inprocess-45day-wall"]["met"] is True
    assert fast["budget-overruns"]["met"] is False and "extrapolated_from_measurements" not in fast["inprocess-45day-wall"]
    # where the CPU goes: per stage label, and what is left outside the stages (500 - 400 us)
    split = {r["name"]: r for r in core_rows(_figures(stage_us={"gating": 100.0, "bank": 300.0}))}["fsw-core-cpu"]
    assert split["stage_us_per_measurement"] == {"gating": 100.0, "bank": 300.0}
    assert split["outside_stages_us_per_measurement"] == pytest.approx(100.0)
    first, second = text_line(split).splitlines()
    assert first.startswith("fsw-core-cpu") and second.strip() == (
        "CPU per measurement by stage (us): bank 300.0, gating 100.0, outside the stages 100.0")
    assert core["stage_us_per_measurement"] is None and "\n" not in text_line(core)


def test_kalman_flops_counts_the_dense_bank_arithmetic():
    # 8 n^3 + 6 n^2 m + 2 n m^2 per filter: ~100 kFLOP for the 3-filter, 16-state bank
    assert kalman_flops(3, 16) == 3 * (8 * 4096 + 6 * 256 + 32)


def test_filter_and_decode_rows_print_json_lines():
    buf = io.StringIO()
    results = run_benchmarks(json=True, quick=True, out=buf, only=lambda g: g in ("filters", "decode"))
    lines = [json.loads(line) for line in buf.getvalue().splitlines()]
    assert [r["name"] for r in lines] == ["linear-bank-vs-filterpy", "ekf-update-vs-filterpy-N3",
                                          "ekf-update-vs-filterpy-N6", "icd-decode", "machine-steadiness"]
    assert lines == json.loads(json.dumps(results))
    *lines, steady = lines
    # the probe was timed before each group that ran and at the end
    assert list(steady["probe_ms"]) == ["filters", "decode", "end"] and steady["points"] == 3
    probes = steady["probe_ms"].values()
    assert steady["ours"] == pytest.approx(max(probes), abs=1e-3)
    assert steady["reference"] == pytest.approx(min(probes), abs=1e-3)
    for r in lines:
        assert ROW_KEYS <= set(r) and isinstance(r["met"], bool)
        assert r["ours"] > 0 and r["reference"] > 0
        # what it ran on: the absolute figures of two runs compare only beside it
        assert r["machine"] == lines[0]["machine"]
        assert r["machine"]["logical_cpus"] == os.cpu_count() and r["machine"]["numpy"] == np.__version__
        assert r["machine"]["cpu"] and isinstance(r["machine"]["blas_core"], str)
    lin, ekf3, ekf6, dec = lines
    assert lin["ratio"] == pytest.approx(lin["reference"] / lin["ours"])
    assert lin["filters"] == 6 and lin["states"] == 15 and lin["measurement_dim"] == 2
    # the arithmetic floor at numpy's batched-matmul rate, and the ratio it would allow
    assert lin["dense_floor_us"] > 0
    assert lin["ratio_ceiling"] == pytest.approx(lin["reference"] / lin["dense_floor_us"])
    assert ekf3["filters"] == 3 and ekf6["filters"] == 6 and ekf3["states"] == ekf6["states"] >= 15
    # stacking the filters must beat running them one by one
    assert lin["ratio"] > 2.0 and ekf6["ratio"] > 1.0
    # the strict decoder is compiled: within a few times json.loads, which checks nothing (the
    # reference decoder alone was ~12x slower)
    assert dec["ratio"] == pytest.approx(dec["ours"] / dec["reference"]) and dec["ratio"] > 0.25
    assert dec["messages"] > 0 and dec["messages_per_s"] == dec["ours"] > 100_000 / 4


def test_without_filterpy_its_rows_are_skipped_with_one_line(monkeypatch, capsys):
    # an entry of None in sys.modules makes `import filterpy...` raise ImportError, as when it
    # is not installed
    monkeypatch.setitem(sys.modules, "filterpy", None)
    monkeypatch.setitem(sys.modules, "filterpy.kalman", None)
    buf = io.StringIO()
    results = run_benchmarks(json=True, quick=True, out=buf, only=lambda g: g in ("filters", "decode"))
    assert [r["name"] for r in results] == ["icd-decode", "machine-steadiness"]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "skipped" in err[0] and "FilterPy" in err[0]


@pytest.mark.slow
def test_quick_bench_has_a_row_for_every_goal():
    buf = io.StringIO()
    rows = run_benchmarks(json=True, quick=True, out=buf)
    names = [r["name"] for r in rows]
    for want in ("fsw-core-cpu", "fsw-core-flop-rate", "inprocess-45day-wall", "budget-overruns", "icd-decode",
                 "linear-bank-vs-filterpy", "ekf-update-vs-filterpy-N3", "ekf-update-vs-filterpy-N6",
                 "campaign-gain-local", "campaign-45day-runs-per-min", "campaign-gain-dask-localcluster",
                 "campaign-gain-dask-scheduler", "machine-steadiness"):
        assert want in names
    for r in rows:
        assert ROW_KEYS <= set(r) and isinstance(r["met"], bool)
        assert not r.get("skipped"), r


def test_campaign_bench_plans_and_cpu_gain(tmp_path):
    from tools.bench.campaigns import cpu_gain, plan_for

    plan = plan_for(2.0, 4, tmp_path, base_seed=101)
    assert [t.seed for t in plan.tasks] == [101, 102, 103, 104]
    assert {t.span_days for t in plan.tasks} == {2.0} and {t.fault_class for t in plan.tasks} == {"none"}
    # runs that take as much CPU side by side as alone: the second worker adds a whole worker
    assert cpu_gain({"run_cpu_s": 1.0}, {"run_cpu_s": 1.0}) == pytest.approx(1.0)
    assert cpu_gain({"run_cpu_s": 1.0}, {"run_cpu_s": 1.25}) == pytest.approx(0.6)
    assert cpu_gain({"run_cpu_s": None}, {"run_cpu_s": 1.0}) is None


def test_a_gain_sets_the_two_worker_rates_against_one_worker_rates_measured_around_them():
    from tools.bench.campaigns import bracketed, cpu_gain

    # the machine speeds up steadily, by 10 % of its first speed per measurement, and a second worker
    # doubles the rate: one worker at 10 then (three measurements later) 13; two at 22 and 24
    order: list[str] = []
    ones = iter([{"runs_per_min": 10.0, "run_cpu_s": 6.0}, {"runs_per_min": 13.0, "run_cpu_s": 4.0}])
    twos = iter([{"runs_per_min": 22.0, "run_cpu_s": 5.5}, {"runs_per_min": 24.0, "run_cpu_s": 4.5}])

    def one():
        order.append("one")
        return next(ones)

    def two():
        order.append("two")
        return next(twos)

    a, b = bracketed(one, two, repeats=2)
    assert order == ["one", "two", "two", "one"]
    # the drift cancels: 23 / 11.5 - 1 = 1, the true gain, where the first 1-worker rate alone
    # would give 1.3 and the last 0.77
    assert (a["runs_per_min"], b["runs_per_min"]) == (11.5, 23.0)
    assert a["runs_per_min_repeats"] == [10.0, 13.0] and b["runs_per_min_repeats"] == [22.0, 24.0]
    assert b["best"] == {"runs_per_min": 24.0, "run_cpu_s": 4.5} and a["best"]["runs_per_min"] == 13.0
    assert (a["run_cpu_s"], b["run_cpu_s"]) == (5.0, 5.0) and cpu_gain(a, b) == pytest.approx(1.0)
    # one repeat (--quick): 1, 2, 1; a measurement without its CPU leaves the side's CPU unknown
    order.clear()
    ones = iter([{"runs_per_min": 8.0, "run_cpu_s": None}, {"runs_per_min": 12.0, "run_cpu_s": 1.0}])
    twos = iter([{"runs_per_min": 19.0, "run_cpu_s": 1.0}])
    a, b = bracketed(one, two, repeats=1)
    assert order == ["one", "two", "one"] and b["runs_per_min"] / a["runs_per_min"] == pytest.approx(1.9)
    assert a["run_cpu_s"] is None


def test_an_in_process_run_says_where_its_cpu_went():
    from tools.bench.core import scenario
    from tools.inprocess import run_in_process

    result = run_in_process(scenario(0.25), 1)
    t = result.timings
    assert t is not None and result.summary.measurements.published > 0
    assert t.resolve_cpu_s >= 0 and t.sim_cpu_s > 0 and t.fsw_cpu_s > 0 and t.summary_cpu_s > 0 and t.wall_s > 0
    # the simulator's faults that start after the shortened arc are dropped, the others kept
    assert scenario(0.25).sim.faults == () and scenario(None).sim.faults


def test_the_bank_alone_is_timed_over_the_runs_own_measurements():
    import math

    from tools.bench.core import bank_alone_us, scenario
    from tools.inprocess import RunResult, run_in_process
    from tools.scenario import load_scenario

    result = run_in_process(scenario(0.25), 1)
    us = bank_alone_us(result, 1)
    assert us is not None and math.isfinite(us) and us > 0
    # without measurements there is nothing to time; the Earth-orbit bank is not the onboard EKF bank
    empty = RunResult(config=result.config, seed=1, messages=[], summary=result.summary)
    assert bank_alone_us(empty, 1) is None
    earth = RunResult(config=load_scenario("leo-injection"), seed=1, messages=[], summary=result.summary)
    assert bank_alone_us(earth, 1) is None


def _processes_with(word: str) -> set[str]:
    """Ids of the running processes whose command line holds ``word``."""
    found = set()
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and word.encode() in (proc / "cmdline").read_bytes():
                found.add(proc.name)
        except OSError:
            pass
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_fsw_startup_cpu_is_read_once_the_fsw_waits_for_data_and_the_process_is_stopped(tmp_path):
    from tools.bench.core import scenario
    from tools.bench.navrun import fsw_startup_cpu
    from tools.scenario import resolve, to_yaml

    cfg, _ = resolve(scenario(1.0), 1)
    path = tmp_path / "config.yaml"
    path.write_text(to_yaml(cfg), encoding="utf-8")
    before = _processes_with("bench-startup")
    cpu = fsw_startup_cpu(path)
    # imports alone (numpy, numba and its kernels) take a good part of a second of CPU
    assert cpu is not None and 0.2 < cpu < 30.0
    assert _processes_with("bench-startup") <= before  # the FSW it started is gone


def test_fsw_startup_cpu_of_a_command_that_exits_is_none(tmp_path):
    from tools.bench.navrun import fsw_startup_cpu

    bad = tmp_path / "config.yaml"
    bad.write_text("fsw: [not, a, mapping]\n", encoding="utf-8")
    assert fsw_startup_cpu(bad, timeout_s=60.0) is None


def _flown_core(mode: str):
    """A short arc of the default scenario through an FswCore in budget mode ``mode``: (the core,
    its BudgetReports)."""
    import dataclasses

    from fsw.core import FswCore
    from fsw.interface import messages as m
    from sim.stream import generate
    from tools.bench.core import scenario
    from tools.scenario import resolve

    cfg, seed = resolve(scenario(0.5), 1)
    budget = dataclasses.replace(cfg.fsw.budget, mode=mode)
    fsw_cfg = dataclasses.replace(cfg.fsw, budget=budget)
    reports = []
    core = FswCore(fsw_cfg, lambda topic, msg: reports.append(msg) if topic == "fsw/budget" else None)
    core.start()
    for _, msg in generate(cfg.sim, seed=seed).iter_messages():
        if isinstance(msg, m.Measurement):
            core.ingest(msg)
    core.finish()
    return core, reports


def test_stage_cpu_from_budget_reports_is_what_the_executive_measured():
    from fsw.interface import codec
    from tools.bench.core import stage_cpu_s

    core, reports = _flown_core("cpu")
    measured = core.executive.stats.cpu_measured_s
    scale = core.config.budget.cpu_scale
    assert measured > 0.0 and len(reports) > 100
    # the reports' charged CPU, unscaled, adds up to the executive's own running total of the
    # stages' measured CPU: no frame that ran a stage went unreported
    assert stage_cpu_s(reports, scale) == pytest.approx(measured, rel=1e-9)
    # the same from the reports as the ground reads them (JSON objects)
    as_json = [json.loads(codec.to_json(r)) for r in reports]
    assert stage_cpu_s(as_json, scale) == pytest.approx(measured, rel=1e-9)
    assert stage_cpu_s([], scale) is None


def test_stage_cpu_of_work_unit_reports_is_unknown():
    from tools.bench.core import stage_cpu_s

    core, reports = _flown_core("work-units")
    assert reports and stage_cpu_s(reports, core.config.budget.cpu_scale) is None


def test_the_status_counts_each_stage_labels_cpu():
    from fsw.core.counters import STAGE_CPU_PREFIX, stage_cpu_by_label
    from fsw.interface import codec, messages as m
    from tools.bench.core import stage_us_per_measurement

    core, _ = _flown_core("cpu")
    measured = core.executive.stage_cpu()
    counts = core.status_counts()
    # what the executive measured, label by label, to the microsecond the counter keeps
    assert set(measured) == {"ingest", "bank", "gating", "telemetry"}
    by_label = stage_cpu_by_label(counts)
    assert set(by_label) == set(measured)
    for label, (runs, cpu) in measured.items():
        assert runs > 100 and abs(by_label[label] - cpu) <= 0.5e-6
    assert sum(by_label.values()) == pytest.approx(core.executive.stats.cpu_measured_s, abs=4 * 0.5e-6)
    # the bank's stage costs more than the ingest's no-op
    assert by_label["bank"] > 10 * by_label["ingest"]
    status = m.RunStatus(t_s=1.0, timestamp=m.Stamp(1, 0), run_id="r", source="fsw", state="end-of-run", counts=counts)
    n = core.bank.processed_count
    per = stage_us_per_measurement([json.loads(codec.to_json(status))], n)
    assert per == pytest.approx({k: v / n * 1e6 for k, v in by_label.items()})
    assert stage_us_per_measurement([status], n) == per and stage_us_per_measurement([], n) == {}
    work, _ = _flown_core("work-units")
    assert not any(key.startswith(STAGE_CPU_PREFIX) for key in work.status_counts())


def test_the_stage_split_compares_label_by_label():
    from tools.bench.navrun import stage_split

    split = stage_split({"bank": 2.4, "gating": 0.9, "rqp": 0.1}, {"bank": 80.0, "gating": 25.0}, 30000)
    assert split["core_stage_cpu_by_label_s"] == pytest.approx({"bank": 2.4, "gating": 0.75})
    # a label the core alone did not run has no ratio
    assert split["stage_cpu_ratio_by_label"] == pytest.approx({"bank": 1.0, "gating": 1.2})
    assert stage_split(None, {"bank": 1.0}, 10)["stage_cpu_ratio_by_label"] is None
    assert stage_split({"bank": 1.0}, None, 10) == {"fsw_stage_cpu_by_label_s": {"bank": 1.0},
                                                    "core_stage_cpu_by_label_s": None, "stage_cpu_ratio_by_label": None}


def test_the_fsw_process_cpu_split_adds_up():
    from tools.bench.navrun import cpu_split

    split = cpu_split(fsw_cpu_s=7.0, startup_s=1.0, fsw_stage_s=3.9, core_cpu_s=3.6, core_stage_s=3.0)
    assert split["stage_cpu_ratio"] == pytest.approx(1.3)
    assert split["fsw_other_cpu_s"] == pytest.approx(2.1) and split["core_other_cpu_s"] == pytest.approx(0.6)
    assert 1.0 + split["fsw_stage_cpu_s"] + split["fsw_other_cpu_s"] == pytest.approx(7.0)
    unknown = cpu_split(fsw_cpu_s=7.0, startup_s=None, fsw_stage_s=3.9, core_cpu_s=3.6, core_stage_s=None)
    assert unknown["fsw_other_cpu_s"] is None and unknown["stage_cpu_ratio"] is None
    assert unknown["core_other_cpu_s"] is None and unknown["fsw_stage_cpu_s"] == 3.9


def test_median_run_is_a_run_that_happened():
    from tools.bench.navrun import median_run

    runs = [{"wall_s": w} for w in (11.2, 9.1, 9.6)]
    assert median_run(runs, lambda r: r["wall_s"]) is runs[2]  # one slow run does not move it
    assert median_run(runs[:2], lambda r: r["wall_s"]) is runs[1]  # even count: the lower middle one
    assert median_run(runs[:1], lambda r: r["wall_s"]) is runs[0]


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_navbank_run_rows_split_the_fsw_process_cpu():
    from tools.bench.core import scenario
    from tools.bench.navrun import navrun_rows

    rows = {r["name"]: r for r in navrun_rows(scenario(0.5), 1, core_cpu_us=100.0, core_stage_cpu_us=80.0,
                                              core_stage_us={"ingest": 1.0, "bank": 60.0, "gating": 16.0,
                                                             "telemetry": 3.0}, runs=2)}
    assert set(rows) == {"budget-overruns-navbank-run", "navbank-run-wall", "navbank-run-fsw-cpu"}
    cpu, wall = rows["navbank-run-fsw-cpu"], rows["navbank-run-wall"]
    assert not cpu.get("skipped"), cpu
    # two runs, each listed; each row is the lower of the two by its own figure
    assert len(wall["wall_s_runs"]) == len(cpu["fsw_cpu_s_runs"]) == 2 == cpu["runs"]
    assert wall["ours"] == pytest.approx(min(wall["wall_s_runs"]), abs=1e-3)
    assert cpu["ours"] == pytest.approx(min(cpu["fsw_cpu_s_runs"]), abs=1e-3)
    n = cpu["measurements"]
    assert n > 100 and cpu["reference"] == pytest.approx(100e-6 * n)
    assert cpu["core_stage_cpu_s"] == pytest.approx(80e-6 * n) and cpu["core_other_cpu_s"] == pytest.approx(20e-6 * n)
    # the stages ran in the FSW process, inside its CPU and after its start-up
    assert 0.0 < cpu["fsw_stage_cpu_s"] < cpu["ours"]
    assert cpu["fsw_startup_cpu_s"] is not None and cpu["fsw_other_cpu_s"] is not None
    assert cpu["fsw_startup_cpu_s"] + cpu["fsw_stage_cpu_s"] + cpu["fsw_other_cpu_s"] == pytest.approx(cpu["ours"])
    assert cpu["stage_cpu_ratio"] == pytest.approx(cpu["fsw_stage_cpu_s"] / cpu["core_stage_cpu_s"])
    # label by label, from the FSW's end-of-run status: they add up to the budget reports' total
    by_label = cpu["fsw_stage_cpu_by_label_s"]
    assert set(by_label) == {"ingest", "bank", "gating", "telemetry"}
    assert sum(by_label.values()) == pytest.approx(cpu["fsw_stage_cpu_s"], abs=1e-3)
    assert cpu["core_stage_cpu_by_label_s"]["bank"] == pytest.approx(60e-6 * n, abs=1e-4)
    assert set(cpu["stage_cpu_ratio_by_label"]) == set(by_label)

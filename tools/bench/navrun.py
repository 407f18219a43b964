"""``navbank run`` rows of ``navbank bench --full``: the three processes over Zenoh on loopback.

* ``navbank-run-wall``: wall time of ``navbank run`` (launcher, ground, FSW and simulator
  processes, summary written) on the default scenario, against the goal figure of 10 s.
* ``navbank-run-fsw-cpu``: CPU seconds of the FSW process over the run against the CPU the same
  FSW core needs in process for as many measurements of the same scenario (:mod:`tools.bench.core`):
  what decoding, encoding, transport and waiting add. Goal ≤ 1.3.
* ``budget-overruns-navbank-run``: the overruns the FSW process reported (its ``summary.json``),
  start-up frames included; goal 0.

The FSW row also says what of the process's CPU is its start-up, a cost fixed per process whatever
the run's length (imports, numba's runtime and the compiled kernels loaded from their cache, the
core built, the session opened): ``fsw_startup_cpu_s`` is the CPU of the same FSW command, on the
run's resolved configuration, once it is up and idle waiting for data (:func:`fsw_startup_cpu`),
and ``ratio_after_startup`` the row's ratio without it.

It also splits the rest in two, on both sides, so that what the ratio measures can be told apart:
``fsw_stage_cpu_s`` is the CPU the executive measured inside the core's stages in the process
(the run's recorded BudgetReports, :func:`tools.bench.core.stage_cpu_s`), ``core_stage_cpu_s``
the same for the core flown alone (scaled to the run's measurements), and ``stage_cpu_ratio``
their quotient: the same stages, on the same data, costing more only because the machine is
shared with the simulator, the logger and Zenoh's threads (caches, memory, a 2-core host's
scheduler). ``fsw_other_cpu_s`` is the process's CPU outside start-up and stages — transport
(receive, decode, encode, publish), checkpoints, and the core's work between stages (executive
bookkeeping, per-frame telemetry) — against ``core_other_cpu_s``, the last of these alone.
The stages are also compared label by label (``fsw_stage_cpu_by_label_s``,
``core_stage_cpu_by_label_s``, ``stage_cpu_ratio_by_label``: the FSW's end-of-run status counts
each label's CPU).

All three always fly the whole default scenario (45 days), ``--quick`` or not: a run's process start
is a fixed cost, which no scaling of a shorter run would show.

``navbank run`` is run three times (``runs``): on a shared host another tenant's load lengthens a
single run by a second or more (the same code measured 9.5 to 11.2 s in consecutive bench runs).
Each row takes the run that is its median — the wall row the run of median wall, the CPU row the
run of median FSW CPU (the lower middle one of an even count) — and lists every run's figure
(``wall_s_runs``, ``fsw_cpu_s_runs``); the overruns row counts the most any run had.

The FSW process's CPU is read from ``/proc/<pid>/stat`` (utime + stime) of the launcher's
``fsw`` child every 50 ms until it exits, so the figure may miss the last 50 ms of it; on a
system without ``/proc`` the row is skipped.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

from fsw.interface import topics
from fsw.transport.session import free_tcp_ports
from ground.mcap_io.reader import McapReadError, read_messages
from fsw.core.counters import stage_cpu_by_label
from tools.bench.core import OVERRUN_GOAL, stage_cpu_s
from tools.bench.rows import Goal, make_row, skipped_row
from tools.scenario import ScenarioConfig, to_yaml

RUN_GOAL_S = 10.0
WALL_GOAL = Goal("cost", ">=", 1.0)
CPU_GOAL = Goal("rate", "<=", 1.3)
POLL_S = 0.05


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(c) for c in text.split()]


def _role(pid: int) -> str | None:
    """The navbank role of a launcher child (``python -m tools.cli ROLE ...``)."""
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return None
    for i, a in enumerate(argv[:-1]):
        if a == b"tools.cli":
            return argv[i + 1].decode(errors="replace")
    return None


def _cpu_s(pid: int) -> float | None:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    # fields after the command: state is [0], utime [11], stime [12] (proc(5) numbers 14 and 15)
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _state(pid: int) -> str | None:
    """The scheduler state of a process's main thread (``R`` running or runnable, ``S`` asleep...)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def fsw_startup_cpu(config: Path, timeout_s: float = 60.0) -> float | None:
    """CPU seconds the FSW command (``navbank fsw --scenario config``, plain TCP on loopback, no
    peers) has used once it is up and waiting for data: read from ``/proc`` every 50 ms until its
    main thread has been asleep at every reading of the last half second and the process has added
    less than 20 ms in it (a process starved of CPU on a busy machine is runnable, not asleep);
    None if it exits or never settles. The process is stopped after."""
    port = free_tcp_ports(1)[0]
    cmd = [sys.executable, "-m", "tools.cli", "fsw", "--scenario", str(config), "--run-id", "bench-startup",
           "--listen", f"tcp/127.0.0.1:{port}", "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        t0 = time.monotonic()
        readings: list[tuple[float, float, bool]] = []  # (when, CPU, asleep)
        while time.monotonic() - t0 < timeout_s and proc.poll() is None:
            c, state = _cpu_s(proc.pid), _state(proc.pid)
            if c is not None:
                now = time.monotonic()
                readings.append((now, c, state == "S"))
                window = [r for r in readings if now - r[0] <= 0.5]
                settled = now - readings[0][0] >= 0.5 and all(asleep for _, _, asleep in window)
                if settled and c - window[0][1] < 0.02:
                    return c
            time.sleep(POLL_S)
        return None
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10.0)


def _run(cfg: ScenarioConfig, seed: int, where: Path, timeout_s: float = 900.0) -> dict[str, Any]:
    """Run ``navbank run`` on ``cfg`` with its output in ``where/run``: its wall time, every role's
    last CPU reading, its measurements and budget (from its summary.json)."""
    scen = where / "scenario.yaml"
    scen.write_text(to_yaml(cfg), encoding="utf-8")
    cmd = [sys.executable, "-m", "tools.cli", "run", "--scenario", str(scen), "--seed", str(seed),
           "--out", str(where / "run"), "--quiet", "--timeout", str(timeout_s)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    cpu: dict[str, float] = {}
    try:
        while proc.poll() is None:
            for child in _children(proc.pid):
                role, c = _role(child), _cpu_s(child)
                if role is not None and c is not None:
                    cpu[role] = max(cpu.get(role, 0.0), c)
            if time.perf_counter() - t0 > timeout_s + 30.0:
                proc.kill()
                break
            time.sleep(POLL_S)
        _, err = proc.communicate(timeout=30.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10.0)
    wall = time.perf_counter() - t0
    try:
        summary = json.loads((where / "run" / "summary.json").read_text())
        published = int(summary["measurements"]["published"])
        budget = {k: summary["budget"][k] for k in ("overruns", "frames", "max_utilisation", "mode")}
    except (OSError, ValueError, KeyError, TypeError):
        published, budget = 0, {}
    return {"wall_s": wall, "cpu_s": cpu, "returncode": proc.returncode, "stderr_tail": (err or "")[-400:],
            "measurements": published, "budget": budget, "run_dir": where / "run"}


def run_details(res: dict[str, Any], cfg: ScenarioConfig) -> dict[str, Any]:
    """What the CPU row says of a run (:func:`_run`'s ``res``, its directory still there): the CPU
    inside the core's stages from its recorded BudgetReports, per label from the FSW's last status,
    and the CPU of its FSW command's start-up (:func:`fsw_startup_cpu`). Read for one run only:
    each costs about a second."""
    run_dir: Path = res["run_dir"]
    stages, by_label = None, None
    try:
        if res["returncode"] == 0:
            mcap = run_dir / "run.mcap"
            reports = read_messages(mcap, topics.FSW_BUDGET)
            stages = stage_cpu_s((lm.message for lm in reports), cfg.fsw.budget.cpu_scale)
            statuses = [lm.message for lm in read_messages(mcap, topics.FSW_STATUS) if lm.message is not None]
            by_label = stage_cpu_by_label(statuses[-1].counts) if statuses else None
    except (OSError, McapReadError):
        stages, by_label = None, None
    # the run's own resolved configuration (seed and a-priori state fixed), as its FSW read it
    resolved = run_dir / "config.yaml"
    startup = fsw_startup_cpu(resolved) if res["returncode"] == 0 and resolved.is_file() else None
    return {"fsw_startup_cpu_s": startup, "fsw_stage_cpu_s": stages, "fsw_stage_cpu_by_label_s": by_label or None}


def median_run(results: list[dict[str, Any]], key: Callable[[dict[str, Any]], float]) -> dict[str, Any]:
    """The run whose ``key`` is the median of ``results`` (the lower middle one of an even count):
    a figure some run really had, which one run slowed by other load on the host does not move."""
    ordered = sorted(results, key=key)
    return ordered[(len(ordered) - 1) // 2]


def navrun_rows(cfg: ScenarioConfig, seed: int, core_cpu_us: float, core_stage_cpu_us: float | None = None,
                core_stage_us: dict[str, float] | None = None, runs: int = 3) -> list[dict[str, Any]]:
    """The rows from ``runs`` runs of ``navbank run`` (see the module docstring); ``core_cpu_us`` is
    the in-process FSW core's CPU per measurement for the same scenario (:mod:`tools.bench.core`,
    possibly over a shorter arc: the reference is that figure times the run's measurements),
    ``core_stage_cpu_us`` the part of it inside its stages and ``core_stage_us`` that part per
    stage label."""
    if not Path("/proc/self/stat").exists():
        return [skipped_row("navbank-run-wall", "s wall", WALL_GOAL, "needs /proc"),
                skipped_row("navbank-run-fsw-cpu", "s CPU", CPU_GOAL, "needs /proc")]
    results = []
    with tempfile.TemporaryDirectory(prefix="navbank-bench-run-") as tmp:
        for k in range(max(runs, 1)):
            (Path(tmp) / str(k)).mkdir()
            res = _run(cfg, seed, Path(tmp) / str(k))
            if res["returncode"] != 0 or not res["measurements"]:
                reason = f"navbank run exited {res['returncode']}: {res['stderr_tail'].strip().splitlines()[-1:]}"
                return [skipped_row("navbank-run-wall", "s wall", WALL_GOAL, reason),
                        skipped_row("navbank-run-fsw-cpu", "s CPU", CPU_GOAL, reason)]
            results.append(res)
        walled = median_run(results, lambda r: r["wall_s"])
        res = median_run(results, lambda r: r["cpu_s"].get("fsw", 0.0))
        res.update(run_details(res, cfg))  # the CPU row's run only
    every = {"runs": len(results), "wall_s_runs": [round(r["wall_s"], 3) for r in results],
             "fsw_cpu_s_runs": [round(r["cpu_s"].get("fsw", 0.0), 3) for r in results]}

    def common(r: dict[str, Any]) -> dict[str, Any]:
        return {"span_days": cfg.sim.trajectory.span_days, "seed": seed, "measurements": r["measurements"],
                "process_cpu_s": r["cpu_s"], **every}

    core_cpu_s = core_cpu_us * 1e-6 * res["measurements"]
    fsw_cpu, startup = res["cpu_s"].get("fsw", 0.0), res["fsw_startup_cpu_s"]
    split = cpu_split(fsw_cpu, startup, res["fsw_stage_cpu_s"], core_cpu_s,
                      None if core_stage_cpu_us is None else core_stage_cpu_us * 1e-6 * res["measurements"])
    budgets = [r["budget"] for r in results if r["budget"]]
    worst = max(budgets, key=lambda b: b["overruns"], default=None)
    overruns = ([make_row("budget-overruns-navbank-run", worst["overruns"], worst["frames"], "overruns", OVERRUN_GOAL,
                          "overruns of the FSW process at the nominal budget incl. its start-up, the most of any "
                          "run (reference: frames run)", budget_mode=worst["mode"],
                          max_utilisation=max(b["max_utilisation"] for b in budgets), **common(res))]
                if worst is not None else [skipped_row("budget-overruns-navbank-run", "overruns", OVERRUN_GOAL,
                                                       "no summary.json")])
    return overruns + [
        make_row("navbank-run-wall", walled["wall_s"], RUN_GOAL_S, "s wall", WALL_GOAL,
                 "goal figure 10 s / ours, the median run (>= 1 meets navbank run <= 10 s)", **common(walled)),
        make_row("navbank-run-fsw-cpu", fsw_cpu, core_cpu_s, "s CPU", CPU_GOAL,
                 "FSW process CPU, the median run / the same FSW core's CPU in process (<= 1.3)", core_cpu_us=core_cpu_us,
                 fsw_startup_cpu_s=startup,
                 ratio_after_startup=None if startup is None or core_cpu_s <= 0.0 else (fsw_cpu - startup) / core_cpu_s,
                 **split, **stage_split(res["fsw_stage_cpu_by_label_s"], core_stage_us, res["measurements"]),
                 **common(res)),
    ]


def cpu_split(fsw_cpu_s: float, startup_s: float | None, fsw_stage_s: float | None, core_cpu_s: float,
              core_stage_s: float | None) -> dict[str, float | None]:
    """The FSW process's CPU and the core's alone, each split into stages and the rest (see the
    module docstring); a part that was not measured is None."""
    known = startup_s is not None and fsw_stage_s is not None
    return {
        "fsw_stage_cpu_s": fsw_stage_s,
        "core_stage_cpu_s": core_stage_s,
        "stage_cpu_ratio": (fsw_stage_s / core_stage_s if fsw_stage_s is not None and core_stage_s else None),
        "fsw_other_cpu_s": fsw_cpu_s - startup_s - fsw_stage_s if known else None,  # type: ignore[operator]
        "core_other_cpu_s": core_cpu_s - core_stage_s if core_stage_s is not None else None,
    }


def stage_split(fsw_by_label_s: dict[str, float] | None, core_us: dict[str, float] | None,
                measurements: int) -> dict[str, dict[str, float] | None]:
    """The stages' CPU label by label: in the process (seconds), the core's alone scaled to the
    run's measurements (seconds), and their quotient — which stages the shared machine slows."""
    core_s = None if core_us is None else {k: v * 1e-6 * measurements for k, v in core_us.items()}
    ratio = None
    if fsw_by_label_s and core_s:
        ratio = {k: round(v / core_s[k], 3) for k, v in fsw_by_label_s.items() if core_s.get(k)}
    return {
        "fsw_stage_cpu_by_label_s": _rounded(fsw_by_label_s),
        "core_stage_cpu_by_label_s": _rounded(core_s),
        "stage_cpu_ratio_by_label": ratio,
    }


def _rounded(seconds: dict[str, float] | None) -> dict[str, float] | None:
    return None if seconds is None else {k: round(v, 4) for k, v in seconds.items()}


__all__ = ["cpu_split", "stage_split", "fsw_startup_cpu", "median_run", "navrun_rows", "run_details"]

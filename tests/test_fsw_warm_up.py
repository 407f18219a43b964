"""Start-up: the first job of each measurement kind is flown once on a copy of the core before any
frame runs it, so its one-time costs are not charged to the flight budget — and the warm-up
changes no output."""

from __future__ import annotations

import dataclasses
import json
import pickle
import subprocess
import sys
from pathlib import Path

import pytest

from fsw.core import FswCore
from fsw.interface import codec, messages as m
from sim.stream import generate
from tools.scenario import load_scenario, resolve

ROOT = Path(__file__).resolve().parents[1]
DAY_S = 86400.0


@pytest.fixture(scope="module")
def first_day():
    """The default scenario's FSW configuration and its first simulated day of measurements."""
    resolved, seed = resolve(load_scenario("insight-approach"), 1)
    run = generate(resolved.sim, seed=seed)
    meas = [msg for _, msg in run.iter_messages() if isinstance(msg, m.Measurement)]
    return resolved.fsw, [x for x in meas if x.t_s <= meas[0].t_s + DAY_S]


def _fly(fsw, measurements, warm_up: bool) -> tuple[FswCore, list[tuple[str, bytes]]]:
    out: list[tuple[str, bytes]] = []
    core = FswCore(fsw, lambda topic, msg: out.append((topic, codec.to_json(msg))), run_id="warm")
    if warm_up:
        core._warm_kinds = set()  # work-unit cores do not warm up by themselves
    core.start()
    for x in measurements:
        core.ingest(x)
    core.finish()
    return core, out


def test_warm_up_changes_no_output(first_day):
    fsw, measurements = first_day
    units = dataclasses.replace(fsw, budget=dataclasses.replace(fsw.budget, mode="work-units"))
    cold, plain = _fly(units, measurements, warm_up=False)
    warm, warmed = _fly(units, measurements, warm_up=True)
    assert cold._warm_kinds is None
    assert warm._warm_kinds == {x.kind for x in measurements} == {"range", "doppler", "optical"}
    assert warmed == plain  # every message, budget reports included, byte for byte


_COLD_FSW = """
import json, pickle, sys
fsw, measurements = pickle.load(open(sys.argv[1], "rb"))
from fsw.core import FswCore
budget = []
core = FswCore(fsw, lambda topic, msg: budget.append(msg) if topic == "fsw/budget" else None, run_id="cold")
core.start()
for x in measurements:
    core.ingest(x)
print(json.dumps({"overruns": budget[-1].overruns, "frames": [[b.frame, b.utilisation] for b in budget]}))
"""


def test_start_up_frames_do_not_overrun_in_cpu_mode(first_day, tmp_path):
    """A fresh process, as `navbank fsw` starts, flies the default scenario's first day at the
    nominal CPU budget: no overrun, and the first frame — which used to carry every one-time
    cost of the first measurement (0.8 of the budget on a quiet machine, 1.3–1.7 in a run of
    three processes) — costs about what a frame of the first hour costs."""
    fsw, measurements = first_day
    assert fsw.budget.mode == "cpu"
    data = tmp_path / "first-day.pkl"
    data.write_bytes(pickle.dumps((fsw, measurements)))
    proc = subprocess.run([sys.executable, "-c", _COLD_FSW, str(data)], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout)
    frames = dict(result["frames"])
    assert result["overruns"] == 0, frames
    assert frames[0] < 0.5, f"first frame at {frames[0]:.2f} of the budget"

"""Kernels named by the measurement models are loaded with the FSW core, not with the configuration:
a process that only reads a scenario (the launcher, the simulator, the ground tools) imports
neither numba nor the scipy solvers."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

from fsw import kernels

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "scipy.optimize", "scipy.integrate", "scipy.interpolate")


def test_reading_a_scenario_imports_no_compiler_or_solver():
    code = ("import sys\nfrom tools.scenario import load_scenario\nimport tools.commands.run, tools.commands.sim\n"
            "load_scenario('insight-approach')\n"
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_building_the_core_binds_every_kernel():
    code = ("from fsw.core import FswCore\nfrom tools.scenario import load_scenario, resolve\n"
            "import fsw.models.optical as o, fsw.models.radiometric as r, fsw.filters.radiometric_kinds as k\n"
            "names = [o.pinhole_image, r.uplink_light_time, r.uplink_reception, r.uplink_solution, k.doppler_prediction]\n"
            "before = [type(f).__name__ for f in names]\n"
            "cfg, _ = resolve(load_scenario('insight-approach'), 1)\n"
            "FswCore(cfg.fsw, lambda t, m: None)\n"
            "names = [o.pinhole_image, r.uplink_light_time, r.uplink_reception, r.uplink_solution, k.doppler_prediction]\n"
            "print(before, [type(f).__name__ for f in names])")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    before, after = out.stdout.strip().split("] [")
    assert before.count("function") == 5  # stand-ins until the core is built
    assert after.count("CPUDispatcher") == 5  # numba's compiled kernels after


def test_a_stand_in_replaces_itself_on_first_call():
    ns: dict = {}
    ns["sqrt"] = kernels.on_first_call(ns, "sqrt", "math")
    stand_in = ns["sqrt"]
    assert stand_in is not math.sqrt
    assert stand_in(9.0) == 3.0
    assert ns["sqrt"] is math.sqrt  # later calls go straight to the function


def test_load_all_binds_the_stand_ins_not_yet_called():
    ns: dict = {}
    ns["floor"] = kernels.on_first_call(ns, "floor", "math")
    kernels.load_all()
    assert ns["floor"] is math.floor

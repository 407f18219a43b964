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


def _kernel_types(code: str) -> list[str]:
    """Run ``code`` in a fresh interpreter; the lines it printed (each the type names of some
    kernels at one moment: ``function`` for a stand-in, ``CPUDispatcher`` once bound)."""
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip().splitlines()


def test_building_the_core_binds_every_kernel():
    before, after = _kernel_types(
        "from fsw.core import FswCore\nfrom tools.scenario import load_scenario, resolve\n"
        "import fsw.models.optical as o, fsw.models.radiometric as r, fsw.filters.radiometric_kinds as k\n"
        "def types():\n"
        "    names = [o.pinhole_image, r.uplink_light_time, r.uplink_reception, r.uplink_solution, k.doppler_prediction]\n"
        "    print([type(f).__name__ for f in names])\n"
        "types()\n"
        "cfg, _ = resolve(load_scenario('insight-approach'), 1)\n"
        "FswCore(cfg.fsw, lambda t, m: None)\n"
        "types()\n")
    assert before.count("function") == 5  # stand-ins until the core is built
    assert after.count("CPUDispatcher") == 5  # numba's compiled kernels after


def test_the_fsw_process_binds_every_kernel_before_it_opens_its_session():
    """The peers of a run wait minutes for the FSW's session to open but seconds for its
    subscriptions after that: kernels compiled after the session opened (a machine's first run)
    made the simulator give up on the FSW."""
    before, at_open = _kernel_types(
        "import fsw.app as app, fsw.models.optical as o, fsw.filters.radiometric_kinds as k\n"
        "from tools.scenario import load_scenario, resolve\n"
        "def types():\n"
        "    print([type(f).__name__ for f in (o.pinhole_image, k.doppler_step, k.doppler_prediction)])\n"
        "class Opened(Exception):\n    pass\n"
        "def lifecycle(*args, **kwargs):\n    types()\n    raise Opened\n"
        "app.tp.ProcessLifecycle = lifecycle\n"
        "cfg, _ = resolve(load_scenario('insight-approach'), 1)\n"
        "types()\n"
        "try:\n    app.run_fsw(cfg.fsw, 'run')\nexcept Opened:\n    pass\n")
    assert before.count("function") == 3  # stand-ins while the scenario is read
    assert at_open.count("CPUDispatcher") == 3  # compiled (or loaded) before the session opens


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


def _modules_after(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code + f"\nimport sys\nprint(sorted(m for m in {HEAVY!r} if m in sys.modules))"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return eval(out.stdout.strip().splitlines()[-1])


def test_the_fsw_loads_scipy_optimize_only_for_an_adaptation(tmp_path):
    """SLSQP (the RQP adaptation) and linprog (adaptive process noise) are loaded while the core
    is built when it needs them, never in a frame; otherwise not at all (0.3 s of a start). The
    FSW reads a resolved scenario (the launcher's config.yaml), as here."""
    import dataclasses

    from tools.scenario import load_scenario, resolve, to_yaml

    def modules(name: str, rqp: bool) -> list[str]:
        cfg, _ = resolve(load_scenario(name), 1)
        if rqp:
            cfg = dataclasses.replace(cfg, fsw=dataclasses.replace(cfg.fsw, rqp=dataclasses.replace(cfg.fsw.rqp, enabled=True)))
        path = tmp_path / f"{name}-{rqp}.yaml"
        path.write_text(to_yaml(cfg, complete=True), encoding="utf-8")
        return _modules_after("from fsw.core import FswCore\nfrom tools.scenario import load_scenario, resolve\n"
                              f"cfg, _ = resolve(load_scenario({str(path)!r}), 1)\nFswCore(cfg.fsw, lambda t, m: None)")

    plain = modules("insight-approach", rqp=False)
    assert "numba" in plain and "scipy.optimize" not in plain
    assert "scipy.optimize" in modules("insight-approach", rqp=True)
    assert "scipy.optimize" in modules("leo-injection", rqp=False)  # its filters adapt their process noise


def test_summarising_a_recorded_run_imports_no_compiler(tmp_path):
    """``navbank run`` writes its summary once its processes have ended, on the critical path of
    its wall time: reading the recording must load neither the FSW's kernels (numba and the cached
    kernels cost ~0.7 s there) nor a solver."""
    import shutil

    shutil.copy(ROOT / "tests" / "golden" / "insight-4day.mcap", tmp_path / "run.mcap")
    code = ("import sys\nfrom pathlib import Path\nfrom tools.scenario import load_scenario, resolve\n"
            f"cfg, seed = resolve(load_scenario({str(ROOT / 'tests' / 'golden' / 'insight-4day.yaml')!r}), 1)\n"
            f"before = set(sys.modules)\n"
            "from tools.commands.run import _summary\n"
            f"s = _summary(cfg, seed, 'golden', Path({str(tmp_path)!r}), None, 1.0, 'complete')\n"
            "print(s.measurements.processed > 0)\n"
            f"print(sorted(m for m in {HEAVY!r} if m in set(sys.modules) - before))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "[]"]

"""The design initial state kept on disk (sim/trajectories/design_cache.py): reused only for the
same configuration, code and numerics, to the bit; anything wrong with the cache means computing."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.trajectories import design_cache, insight
from sim.trajectories.design import initial_state

ROOT = Path(__file__).resolve().parents[1]
CFG = TrajectoryConfig()
FORCES = ForceModelConfig()

# a fresh process: the state of the default trajectory as resolve gets it, and whether it needed
# scipy's integrators for it
PROBE = """
import json, sys
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.trajectories.design import initial_state
t0, x0 = initial_state(TrajectoryConfig(), ForceModelConfig())
print(json.dumps({"t0": t0, "x0": [float(v) for v in x0], "integrated": "scipy.integrate" in sys.modules}))
"""


def _probe(cache: Path, **env: str) -> dict:
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "NAVBANK_CACHE_DIR": str(cache), **env}, check=True)
    return json.loads(out.stdout)


def _direct() -> tuple[float, np.ndarray]:
    """The state computed without the cache (the trajectory's own function)."""
    return insight.insight_initial_state(CFG, FORCES)


def _files(cache: Path) -> list[Path]:
    return sorted((cache / "design-states").glob("*.json"))


def test_a_second_process_reads_the_state_the_first_computed_to_the_bit(tmp_path):
    t0, x0 = _direct()
    first = _probe(tmp_path)
    assert first["integrated"] and len(_files(tmp_path)) == 1
    second = _probe(tmp_path)
    assert not second["integrated"]  # read back: no integration, not even scipy's import
    for got in (first, second):
        assert got["t0"] == t0 and got["x0"] == x0.tolist()


def test_another_configuration_or_kernel_is_another_file(tmp_path, monkeypatch):
    monkeypatch.setenv("NAVBANK_CACHE_DIR", str(tmp_path))
    shorter = dataclasses.replace(CFG, span_days=30.0)
    assert design_cache.key(CFG, FORCES) != design_cache.key(shorter, FORCES)
    t_short, x_short = initial_state(shorter, FORCES)
    assert (t_short, x_short.tolist()) == tuple(v.tolist() if isinstance(v, np.ndarray) else v
                                                for v in insight.insight_initial_state(shorter, FORCES))
    assert len(_files(tmp_path)) == 1
    # numpy on another OpenBLAS kernel rounds the integration's products its own way: its own file
    forced = _probe(tmp_path, OPENBLAS_CORETYPE="Haswell")
    assert forced["integrated"] and len(_files(tmp_path)) == 2


@pytest.mark.parametrize("damage", ["", "{not json", '{"t0": 1.0}', "nan-state", "other-key", "five-components"])
def test_a_damaged_file_is_recomputed_and_rewritten(tmp_path, monkeypatch, damage):
    monkeypatch.setenv("NAVBANK_CACHE_DIR", str(tmp_path))
    t0, x0 = initial_state(CFG, FORCES)
    (path,) = _files(tmp_path)
    good = json.loads(path.read_text())
    text = {"nan-state": json.dumps({**good, "x0": [float("nan")] * 6}),
            "other-key": json.dumps({**good, "key": "0" * 64}),
            "five-components": json.dumps({**good, "x0": good["x0"][:5]})}.get(damage, damage)
    path.write_text(text)
    again_t0, again_x0 = initial_state(CFG, FORCES)
    assert again_t0 == t0 and again_x0.tolist() == x0.tolist()
    assert json.loads(path.read_text()) == good


def test_an_unusable_cache_directory_only_means_computing(tmp_path, monkeypatch):
    blocker = tmp_path / "not-a-directory"
    blocker.write_text("")
    monkeypatch.setenv("NAVBANK_CACHE_DIR", str(blocker))
    t0, x0 = initial_state(CFG, FORCES)
    d_t0, d_x0 = _direct()
    assert t0 == d_t0 and x0.tolist() == d_x0.tolist()


def test_a_process_without_a_home_directory_computes(monkeypatch):
    def no_home():
        raise RuntimeError("Could not determine home directory.")

    for var in ("NAVBANK_CACHE_DIR", "XDG_CACHE_HOME"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(Path, "home", staticmethod(no_home))
    assert design_cache.cache_dir() is None
    t0, x0 = initial_state(CFG, FORCES)
    d_t0, d_x0 = _direct()
    assert t0 == d_t0 and x0.tolist() == d_x0.tolist()


def test_the_key_covers_every_source_of_sim_and_fsw(tmp_path, monkeypatch):
    stamp = design_cache.source_stamp()
    sources = [p for pkg in ("sim", "fsw") for p in sorted((ROOT / pkg).rglob("*.py"))]
    assert len(sources) > 100 and ROOT / "sim" / "dynamics" / "propagator.py" in sources
    design_cache.source_stamp.cache_clear()
    try:
        # a copy of the tree with one source changed stamps differently
        copy = tmp_path / "tree"
        for p in sources:
            dst = copy / p.relative_to(ROOT)
            dst.parent.mkdir(parents=True, exist_ok=True)
            dst.write_bytes(p.read_bytes())
        monkeypatch.setattr(design_cache, "__file__", str(copy / "sim" / "trajectories" / "design_cache.py"))
        assert design_cache.source_stamp() == stamp
        design_cache.source_stamp.cache_clear()
        prop = copy / "sim" / "dynamics" / "propagator.py"
        prop.write_bytes(prop.read_bytes() + b"\n# changed\n")
        assert design_cache.source_stamp() != stamp
    finally:
        design_cache.source_stamp.cache_clear()

"""Where the compiled kernels are cached, and that they are ready when the FSW core is built."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from fsw.kernels import cache

ROOT = Path(__file__).resolve().parents[1]


def test_cache_dir_is_left_to_numba_when_the_package_is_writable(monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(cache, "_writable", lambda path: True)
    cache.configure_cache_dir()
    assert "NUMBA_CACHE_DIR" not in __import__("os").environ


def test_unwritable_package_dir_falls_back_to_a_writable_cache(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "ro"))
    monkeypatch.setattr(cache.tempfile, "gettempdir", lambda: str(tmp_path / "tmp"))
    writable_parent = tmp_path / "tmp"
    monkeypatch.setattr(cache, "_writable", lambda path: writable_parent in Path(path).parents)
    cache.configure_cache_dir()
    import os

    chosen = Path(os.environ["NUMBA_CACHE_DIR"])
    assert chosen.parent == writable_parent and chosen.name.startswith("navbank-numba-")


def test_an_explicit_cache_dir_is_kept(monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/somewhere/chosen")
    monkeypatch.setattr(cache, "_writable", lambda path: False)
    cache.configure_cache_dir()
    import os

    assert os.environ["NUMBA_CACHE_DIR"] == "/somewhere/chosen"


def test_kernels_are_compiled_before_the_core_starts():
    """Building the core loads every kernel (explicit signatures); start() and the first frames
    compile nothing."""
    code = """
import numba.core.dispatcher as d
from fsw.config import FswConfig
from fsw.core.fswcore import FswCore
from fsw.kernels import camera, count_start, doppler, joseph_update, light_time, time_update, variational_rk4
kernels = [variational_rk4.rk4_variational, time_update.time_update, joseph_update.joseph_update,
           light_time.uplink_reception, light_time.uplink_light_time, light_time.uplink_solution,
           count_start.count_start_from_leg,
           doppler.doppler_prediction, camera.pinhole_image]
assert all(len(k.signatures) == 1 and k._can_compile is False for k in kernels), [k.signatures for k in kernels]
print("ok")
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0 and "ok" in proc.stdout, proc.stderr[-3000:]

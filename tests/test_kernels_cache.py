"""Where the compiled kernels are cached, and that they are ready when the FSW core is built."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from fsw.kernels import cache

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def numba_cache_dir_restored():
    """The process's ``NUMBA_CACHE_DIR`` (and numba's configuration read from it) as before the
    test, whatever :func:`cache.configure_cache_dir` set: the tests after it, and the processes
    they start, must compile into and load from the cache they would have used otherwise (a
    directory left behind here would make the next test compile every kernel anew)."""
    before = os.environ.get("NUMBA_CACHE_DIR")
    yield
    if before is None:
        os.environ.pop("NUMBA_CACHE_DIR", None)
    else:
        os.environ["NUMBA_CACHE_DIR"] = before
    if "numba" in sys.modules:
        from numba.core import config

        config.reload_config()


def test_cache_dir_is_left_to_numba_when_the_package_is_writable(monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(cache, "_writable", lambda path: True)
    cache.configure_cache_dir()
    assert "NUMBA_CACHE_DIR" not in os.environ


def test_unwritable_package_dir_falls_back_to_a_writable_cache(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "ro"))
    monkeypatch.setattr(cache.tempfile, "gettempdir", lambda: str(tmp_path / "tmp"))
    writable_parent = tmp_path / "tmp"
    monkeypatch.setattr(cache, "_writable", lambda path: writable_parent in Path(path).parents)
    cache.configure_cache_dir()
    chosen = Path(os.environ["NUMBA_CACHE_DIR"])
    assert chosen.parent == writable_parent and chosen.name.startswith("navbank-numba-")


def test_an_explicit_cache_dir_is_kept(monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/somewhere/chosen")
    monkeypatch.setattr(cache, "_writable", lambda path: False)
    cache.configure_cache_dir()
    assert os.environ["NUMBA_CACHE_DIR"] == "/somewhere/chosen"


def test_kernels_are_compiled_before_the_core_starts():
    """Building the core loads every kernel (explicit signatures); start() and the first frames
    compile nothing."""
    code = """
import numba.core.dispatcher as d
from fsw.config import FswConfig
from fsw.core.fswcore import FswCore
from fsw.kernels import (camera, count_start, doppler, joseph_update, light_time, one_way_range, radiometric_step,
                         time_update,
                         variational_rk4)
kernels = [variational_rk4.rk4_variational, time_update.time_update, joseph_update.joseph_update,
           light_time.uplink_reception, light_time.uplink_light_time, light_time.uplink_solution,
           count_start.count_start_from_leg,
           doppler.doppler_prediction, one_way_range.range_prediction, camera.pinhole_image, radiometric_step.doppler_step,
           radiometric_step.doppler_finish, radiometric_step.range_step, radiometric_step.range_finish]
assert all(len(k.signatures) == 1 and k._can_compile is False for k in kernels), [k.signatures for k in kernels]
print("ok")
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0 and "ok" in proc.stdout, proc.stderr[-3000:]


def _sha_of_sources(directory: Path) -> str:
    h = hashlib.sha256()
    for name in sorted(p.name for p in directory.iterdir() if p.suffix == ".py"):
        h.update(name.encode() + b"\0" + (directory / name).read_bytes())
    return h.hexdigest()


def test_every_kernel_is_stamped_with_all_the_kernel_sources():
    """A fused kernel carries copies of the kernels it calls: its cache must go stale when any
    kernel's source changes, not only its own file."""
    from fsw.kernels import joseph_update, radiometric_step, variational_rk4

    expected = _sha_of_sources(ROOT / "fsw" / "kernels")
    for kernel in (radiometric_step.doppler_step, joseph_update.joseph_update, variational_rk4.rk4_variational):
        locator = kernel._cache._impl._locator
        assert isinstance(locator, tuple(cache.LOCATORS)), type(locator)
        assert locator.get_source_stamp() == expected


def test_the_stamp_follows_the_sources_content_not_their_times(tmp_path):
    copy = tmp_path / "kernels"
    shutil.copytree(ROOT / "fsw" / "kernels", copy, ignore=shutil.ignore_patterns("__pycache__"))
    before = cache.source_stamp(copy)
    assert before == _sha_of_sources(copy)
    os.utime(copy / "joseph_update.py", (0, 0))  # a checkout touching only times
    assert cache.source_stamp(copy) == before
    with open(copy / "joseph_update.py", "a") as f:
        f.write("\n")
    assert cache.source_stamp(copy) != before


def test_functions_outside_the_kernels_keep_numbas_own_locators(tmp_path):
    from fsw.kernels import joseph_update  # noqa: F401  (installs the locators)

    other = tmp_path / "elsewhere.py"
    other.write_text("def f():\n    return 1\n")
    namespace: dict = {}
    exec(compile(other.read_text(), str(other), "exec"), namespace)
    assert cache.LOCATORS and all(loc.from_function(namespace["f"], str(other)) is None for loc in cache.LOCATORS)

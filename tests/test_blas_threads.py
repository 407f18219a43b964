"""One BLAS thread per navbank process unless the user chose a number (tools.blas_threads)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tools.blas_threads import SET, THREAD_VARIABLES, one_blas_thread

ROOT = Path(__file__).resolve().parents[1]


def test_one_thread_is_asked_for_when_no_count_is_set():
    env: dict[str, str] = {"PATH": "/bin"}
    assert one_blas_thread(env) is True
    assert env == {"PATH": "/bin", **{name: "1" for name in SET}}


@pytest.mark.parametrize("name", THREAD_VARIABLES)
def test_a_count_the_user_set_is_left_alone(name):
    env = {name: "4"}
    assert one_blas_thread(env) is False
    assert env == {name: "4"}


# Threads of a process after numpy has done a matrix product: its OpenBLAS pool, if it has one.
_COUNT = ("import numpy; numpy.ones((64, 64)) @ numpy.ones((64, 64)); "
          "print([l for l in open('/proc/self/status') if l.startswith('Threads:')][0].split()[1])")
# The same after a process's own command line ran through tools.cli.main.
_PROBE = ("import contextlib, io, sys; sys.argv = ['navbank', 'scenarios']; from tools.cli import main\n"
          "with contextlib.redirect_stdout(io.StringIO()):\n    main()\n" + _COUNT)


def _threads(code: str, **env: str) -> int:
    clean = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env={**clean, **env}, capture_output=True,
                         text=True, timeout=120, check=True)
    return int(out.stdout.split()[-1])


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc")
def test_a_process_command_line_runs_without_a_blas_thread_pool():
    pooled = _threads(_COUNT)
    if pooled == 1:
        pytest.skip("one CPU: OpenBLAS starts no pool to compare with")
    assert _threads(_PROBE) == 1
    # a count the user set is what the process gets
    assert _threads(_PROBE, OPENBLAS_NUM_THREADS="2") == 2

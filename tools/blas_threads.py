"""One BLAS thread per navbank process, unless the user chose a number.

numpy and scipy each load an OpenBLAS that starts a pool of threads (one per core) when it is
loaded. navbank's linear algebra is on 3×3 to 16×16 matrices, which OpenBLAS does on the
calling thread anyway; the pools only cost their start and their busy-waiting, and on a machine
whose cores run the simulator, the FSW and the logger (or a campaign's workers, one per core)
they compete with the work. Measured on the default scenario (``navbank run``, 2 cores, three
runs each): the FSW command's start-up took 0.63-0.65 s of CPU with one BLAS thread against
0.82-0.91 s with the pools, the FSW process 5.75-6.11 s against 5.97-6.50 s, the simulator
1.64-1.74 s against 1.80-1.96 s, and the run's wall time 8.3-8.8 s against 8.6-9.3 s.

The library reads the variable when it is loaded, so :func:`one_blas_thread` must run before
numpy is first imported: :func:`tools.cli.main` calls it for a process's own command line, and
the processes a command starts (the launcher's three, a campaign's workers) inherit it.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping

#: Variables the BLAS builds numpy and scipy may use read for their thread count (OpenBLAS its own
#: first, then OMP_NUM_THREADS); the user having set any of them is a choice left alone.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                    "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")
#: What is set when the user set none of them.
SET = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def one_blas_thread(environ: MutableMapping[str, str] | None = None) -> bool:
    """Ask the BLAS libraries for one thread in ``environ`` (default: this process's environment)
    unless a thread count is already set there; returns whether it set one."""
    env = os.environ if environ is None else environ
    if any(name in env for name in THREAD_VARIABLES):
        return False
    for name in SET:
        env[name] = "1"
    return True

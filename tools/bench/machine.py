"""The machine a benchmark ran on, carried in every ``navbank bench`` row.

The rows whose goals are absolute figures (µs per measurement, seconds, runs per minute) depend
on the processor: Python's own speed and the kernel OpenBLAS picks for it (Haswell with AVX2,
SkylakeX with AVX-512, ...), which also decides the last bits of numpy's small matrix products.
Rows of two runs are comparable only with this beside them.
"""

from __future__ import annotations

import os
import platform
from functools import lru_cache
from typing import Any

import numpy as np

from sim.numerics import blas_core


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


@lru_cache(maxsize=1)
def machine() -> dict[str, Any]:
    """Processor, logical CPUs, Python and numpy versions, and numpy's OpenBLAS kernel."""
    return {"cpu": _cpu_model(), "logical_cpus": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "blas_core": blas_core()}


__all__ = ["blas_core", "machine"]

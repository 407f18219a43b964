"""The OpenBLAS kernel numpy runs on, and how to run a check on the kernel a recording was made with.

numpy picks its OpenBLAS kernel for the CPU at hand (Haswell on an AVX2 machine, SkylakeX with
AVX-512, ...), and the kernels round products in different orders: arithmetic that goes through
BLAS (small matrix products included) agrees across kernels to the last bits only. Digests and
recordings made on one kernel are therefore compared on that kernel, in a subprocess started with
``OPENBLAS_CORETYPE`` set (the variable is read once, when numpy loads OpenBLAS). numpy's own
float64 loops have the same trouble: on an AVX-512 machine it dispatches to other loops than on
an AVX2 one, so the subprocess also switches numpy's AVX-512 targets off.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from tools.bench.machine import blas_core

GOLDEN = Path(__file__).resolve().parent / "golden"
#: What the committed recordings and digests were made with (``golden/recorded-with.json``).
RECORDED_WITH = json.loads((GOLDEN / "recorded-with.json").read_text())

__all__ = ["GOLDEN", "RECORDED_WITH", "blas_core", "recorded_kernel_env"]


def recorded_kernel_env() -> dict[str, str]:
    """This process's environment with OpenBLAS forced to the recordings' kernel and numpy kept
    off the SIMD targets the recordings did not use (``NPY_DISABLE_CPU_FEATURES``: its float64
    loops round differently on an AVX-512 machine than on an AVX2 one, as OpenBLAS's kernels do)."""
    return {**os.environ, "OPENBLAS_CORETYPE": RECORDED_WITH["blas_core"],
            "NPY_DISABLE_CPU_FEATURES": RECORDED_WITH["numpy_disabled_cpu_features"]}

"""The OpenBLAS kernel numpy runs on, and how to run a check on the kernel a recording was made with.

numpy picks its OpenBLAS kernel for the CPU at hand (Haswell on an AVX2 machine, SkylakeX with
AVX-512, ...), and the kernels round products in different orders: arithmetic that goes through
BLAS (small matrix products included) agrees across kernels to the last bits only. Digests and
recordings made on one kernel are therefore compared on that kernel, in a subprocess started with
``OPENBLAS_CORETYPE`` set (the variable is read once, when numpy loads OpenBLAS).
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
    """This process's environment with OpenBLAS forced to the recordings' kernel."""
    return {**os.environ, "OPENBLAS_CORETYPE": RECORDED_WITH["blas_core"]}

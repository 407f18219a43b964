"""The OpenBLAS kernel numpy runs on, and how to run a check on the kernel a recording was made with.

numpy picks its OpenBLAS kernel for the CPU at hand (Haswell on an AVX2 machine, SkylakeX with
AVX-512, ...), and the kernels round products in different orders: arithmetic that goes through
BLAS (small matrix products included) agrees across kernels to the last bits only. Digests and
recordings made on one kernel are therefore compared on that kernel, in a subprocess started with
``OPENBLAS_CORETYPE`` set (the variable is read once, when numpy loads OpenBLAS).
"""

from __future__ import annotations

import ctypes
import glob
import json
import os
from pathlib import Path

import numpy as np

GOLDEN = Path(__file__).resolve().parent / "golden"
#: What the committed recordings and digests were made with (``golden/recorded-with.json``).
RECORDED_WITH = json.loads((GOLDEN / "recorded-with.json").read_text())


def blas_core() -> str:
    """The OpenBLAS kernel numpy runs on in this process ('' if it cannot be asked)."""
    for lib in glob.glob(os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs", "*openblas*")):
        try:
            f = ctypes.CDLL(lib).scipy_openblas_get_corename64_
        except (OSError, AttributeError):
            continue
        f.restype = ctypes.c_char_p
        return f().decode()
    return ""


def recorded_kernel_env() -> dict[str, str]:
    """This process's environment with OpenBLAS forced to the recordings' kernel."""
    return {**os.environ, "OPENBLAS_CORETYPE": RECORDED_WITH["blas_core"]}

"""What decides the last bits of this process's floating-point results, beyond navbank's own code.

numpy picks its OpenBLAS kernel for the CPU at hand (Haswell with AVX2, SkylakeX with AVX-512, ...,
or the one ``OPENBLAS_CORETYPE`` forces), and the kernels round small matrix products in different
orders; scipy's integrators, pyerfa and the DE421 reader change with their releases. A result kept
across processes (:mod:`sim.trajectories.design_cache`) is reused only where all of these match.
"""

from __future__ import annotations

import ctypes
import glob
import os
import platform
from functools import lru_cache
from importlib import metadata

import numpy as np

#: The distributions whose releases may change a simulated number.
DISTRIBUTIONS = ("numpy", "scipy", "pyerfa", "jplephem", "de421")


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


def _version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return ""


@lru_cache(maxsize=1)
def fingerprint() -> dict[str, str]:
    """Python, the releases of :data:`DISTRIBUTIONS` and numpy's OpenBLAS kernel."""
    return {"python": platform.python_version(), "blas_core": blas_core(),
            **{name: _version(name) for name in DISTRIBUTIONS}}


__all__ = ["DISTRIBUTIONS", "blas_core", "fingerprint"]

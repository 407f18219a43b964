"""Where numba caches compiled kernels.

numba writes its cache next to the sources (``__pycache__``); if that directory is read-only
(an installed package), under ``$HOME/.cache/numba``; if that is unwritable too, importing a
cached kernel fails ("no locator available"). So when the package directory is not writable
and ``NUMBA_CACHE_DIR`` is not set, a writable directory is chosen here before numba is
imported: the user cache directory, else the temporary directory.

Every cached kernel is stamped with all the kernels' sources, not only its own file
(:func:`stamp_with_all_kernel_sources`): a fused kernel calls kernels of other modules.
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from functools import lru_cache
from pathlib import Path
from typing import Any


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(path, os.W_OK | os.X_OK)


def configure_cache_dir() -> None:
    """Set ``NUMBA_CACHE_DIR`` if numba could not cache next to the kernels' sources."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    here = Path(__file__).resolve().parent
    if _writable(here / "__pycache__"):
        return
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    uid = os.getuid() if hasattr(os, "getuid") else 0
    for candidate in (home / "navbank" / "numba", Path(tempfile.gettempdir()) / f"navbank-numba-{uid}"):
        if _writable(candidate):
            os.environ["NUMBA_CACHE_DIR"] = str(candidate)
            if "numba" in sys.modules:  # numba read its configuration at import
                from numba.core import config

                config.reload_config()
            return


_KERNELS = Path(__file__).resolve().parent


def source_stamp(directory: Path) -> str:
    """SHA-256 of the names and bytes of the Python modules in ``directory``."""
    digest = hashlib.sha256()
    for path in sorted(directory.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()


@lru_cache(maxsize=1)
def kernels_source_stamp() -> str:
    """The freshness stamp of every cached kernel: :func:`source_stamp` of this package.

    numba stamps a cached function with its own file's modification time and size, so a kernel
    that calls a kernel of another module (a fused step) would keep the machine code of a callee
    that has since changed. Stamped with all the kernels' sources, a change to any of them
    recompiles every kernel once; a checkout that only touches modification times does not."""
    return source_stamp(_KERNELS)


#: The locators :func:`stamp_with_all_kernel_sources` put in front of numba's (for ``NUMBA_CACHE_DIR``,
#: for ``__pycache__``); empty until then.
LOCATORS: list[type[Any]] = []


def stamp_with_all_kernel_sources() -> None:
    """Put locators in front of numba's own that cache the functions of this package where numba
    would (the user's ``NUMBA_CACHE_DIR``, else ``__pycache__``) but stamp them with
    :func:`kernels_source_stamp`. Any other function keeps numba's locators. Idempotent; called
    by each kernel module after it imports numba."""
    if LOCATORS:
        return
    from numba.core import caching

    class _AllKernelSources:
        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if Path(py_file).resolve().parent != _KERNELS:
                return None
            return super().from_function(py_func, py_file)  # type: ignore[misc]

        def get_source_stamp(self) -> str:
            return kernels_source_stamp()

    class KernelsUserCacheLocator(_AllKernelSources, caching.UserProvidedCacheLocator):
        """numba's locator for ``NUMBA_CACHE_DIR``, stamped with every kernel's source."""

    class KernelsInTreeCacheLocator(_AllKernelSources, caching.InTreeCacheLocator):
        """numba's ``__pycache__`` locator, stamped with every kernel's source."""

    LOCATORS[:] = [KernelsUserCacheLocator, KernelsInTreeCacheLocator]
    caching.CacheImpl._locator_classes[:0] = LOCATORS

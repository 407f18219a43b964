"""Where numba caches compiled kernels.

numba writes its cache next to the sources (``__pycache__``); if that directory is read-only
(an installed package), under ``$HOME/.cache/numba``; if that is unwritable too, importing a
cached kernel fails ("no locator available"). So when the package directory is not writable
and ``NUMBA_CACHE_DIR`` is not set, a writable directory is chosen here before numba is
imported: the user cache directory, else the temporary directory.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path


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

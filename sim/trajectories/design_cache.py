"""The design trajectory's initial state, kept on disk between processes.

Every command that fixes a run's configuration (``navbank run``'s launcher before it starts the
three processes, ``navbank sim``, replay, campaigns' workers) needs the design initial state: a
45-day integration of the design force model back from the entry point. That costs ~0.1 s of
integration after ~0.4 s of importing scipy's integrators, on the critical path of ``navbank run``
(the simulator and the FSW start only once their configuration is written). It is a pure function
of the trajectory and force configuration, of navbank's code and of the numerical libraries, so a
result is kept in a file named by a SHA-256 of all of these:

* the trajectory and force configurations (their canonical JSON);
* every source file of the ``sim`` and ``fsw`` packages (what the integration and its ephemeris,
  frames and time scales run on: a change anywhere in them makes a new key);
* :func:`sim.numerics.fingerprint`: Python, numpy, scipy, pyerfa, jplephem and DE421 releases and
  numpy's OpenBLAS kernel (which rounds small matrix products its own way).

Files live under ``$NAVBANK_CACHE_DIR``, else ``$XDG_CACHE_HOME/navbank`` or ``~/.cache/navbank``
(``design-states/``). A file is written atomically (temporary file, rename) and read back only if
it holds what a state holds (finite numbers, six components, its own key); anything else — a
missing, unreadable, unwritable or damaged cache — means the state is computed, as without it.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

from fsw.interface import typed
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.numerics import fingerprint

FORMAT = "navbank-design-state/1"
_PACKAGES = ("sim", "fsw")


def cache_root() -> Path | None:
    """navbank's cache directory: ``$NAVBANK_CACHE_DIR``, else ``$XDG_CACHE_HOME/navbank`` or
    ``~/.cache/navbank`` (not necessarily existing or writable); None if this process has no home
    directory to put it in."""
    root = os.environ.get("NAVBANK_CACHE_DIR")
    if not root:
        try:
            root = str(Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "navbank")
        except (RuntimeError, KeyError):  # Path.home() of a user without one
            return None
    return Path(root)


def cache_dir() -> Path | None:
    """Where the states are kept (:func:`cache_root`'s ``design-states``); None without a root."""
    root = cache_root()
    return None if root is None else root / "design-states"


@lru_cache(maxsize=1)
def source_stamp() -> str:
    """SHA-256 of the names and bytes of every Python source of the ``sim`` and ``fsw`` packages."""
    root = Path(__file__).resolve().parents[2]
    digest = hashlib.sha256()
    for package in _PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(b"\0")
            digest.update(path.read_bytes())
    return digest.hexdigest()


def key(cfg: TrajectoryConfig, forces: ForceModelConfig) -> str:
    """The name of a state's file: everything the state depends on, hashed."""
    text = json.dumps({"format": FORMAT, "trajectory": typed.encode(cfg), "forces": typed.encode(forces),
                       "sources": source_stamp(), "numerics": fingerprint()}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _read(path: Path, name: str) -> tuple[float, tuple[float, ...]] | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        t0, x0 = data["t0"], data["x0"]
        if data.get("key") != name or data.get("format") != FORMAT:
            return None
        values = (t0, *x0)
        if len(x0) != 6 or not all(type(v) is float and math.isfinite(v) for v in values):
            return None
        return t0, tuple(x0)
    except (OSError, ValueError, TypeError, KeyError):
        return None


def _write(path: Path, name: str, t0: float, x0: tuple[float, ...]) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".state-", suffix=".tmp")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                # repr of a float reads back as the same float: the state is kept to the bit
                json.dump({"format": FORMAT, "key": name, "t0": t0, "x0": list(x0)}, f)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:
        pass  # a cache that cannot be written is no cache: the state was computed all the same


def cached_state(cfg: TrajectoryConfig, forces: ForceModelConfig,
                 compute: Callable[[], tuple[float, tuple[float, ...]]]) -> tuple[float, tuple[float, ...]]:
    """``compute()``'s (t0, state) for this configuration, from the cache if it holds it, else
    computed and kept there."""
    directory = cache_dir()
    name = key(cfg, forces)
    path = None if directory is None else directory / f"{name}.json"
    found = None if path is None else _read(path, name)
    if found is not None:
        return found
    t0, x0 = compute()
    t0, x0 = float(t0), tuple(float(v) for v in x0)
    if path is not None:
        _write(path, name, t0, x0)
    return t0, x0


__all__ = ["FORMAT", "cache_dir", "cached_state", "key", "source_stamp"]

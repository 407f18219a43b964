"""The packages type-check clean under the ``[tool.mypy]`` configuration of pyproject.toml."""

from __future__ import annotations

import os
from pathlib import Path

from mypy import api

ROOT = Path(__file__).resolve().parents[1]

#: The packages checked, as paths from the repository root.
PACKAGES: tuple[str, ...] = ("fsw", "sim", "ground", "tools")


def test_packages_type_check() -> None:
    cache = os.environ.get("MYPY_CACHE_DIR", str(ROOT / ".mypy_cache"))
    stdout, stderr, status = api.run(
        ["--config-file", str(ROOT / "pyproject.toml"), "--cache-dir", cache, "--no-error-summary",
         *(str(ROOT / p) for p in PACKAGES)]
    )
    errors = [line for line in stdout.splitlines() if ": error:" in line]
    assert status == 0 and not errors, "mypy found errors:\n" + stdout + stderr

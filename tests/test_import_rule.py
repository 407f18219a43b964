"""DESIGN.md's import rule is the architecture: check it on the source, not by convention."""

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _imports(package: str):
    for path in sorted((ROOT / package).rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    yield path, node.lineno, alias.name
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                yield path, node.lineno, node.module


def _violations(package: str, allowed) -> list[str]:
    bad = []
    for path, line, name in _imports(package):
        top = name.split(".")[0]
        if top in {"fsw", "sim", "ground", "tools"} and not allowed(name):
            bad.append(f"{path.relative_to(ROOT)}:{line}: imports {name}")
    return bad


def _under(name: str, *prefixes: str) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_fsw_never_imports_sim_ground_or_tools():
    assert _violations("fsw", lambda n: _under(n, "fsw")) == []


def test_fsw_interface_and_astro_stay_at_the_bottom():
    assert _violations("fsw/interface", lambda n: _under(n, "fsw.interface")) == []
    assert _violations("fsw/astro", lambda n: _under(n, "fsw.interface", "fsw.astro")) == []


def test_sim_uses_only_the_icd_transport_and_astro_of_fsw():
    assert _violations("sim", lambda n: _under(n, "sim", "fsw.interface", "fsw.transport", "fsw.astro")) == []


def test_ground_uses_fsw_but_not_sim_or_tools():
    assert _violations("ground", lambda n: _under(n, "ground", "fsw")) == []


def _outside(package: str, *allowed: str) -> list[str]:
    """Imports of ``package`` that are neither the standard library nor under ``allowed``."""
    return [f"{path.relative_to(ROOT)}:{line}: imports {name}" for path, line, name in _imports(package)
            if name.split(".")[0] not in sys.stdlib_module_names and not _under(name, *allowed)]


def test_fsw_interface_imports_only_stdlib_numpy_and_yaml():
    assert _outside("fsw/interface", "fsw.interface", "numpy", "yaml") == []


def test_fsw_transport_imports_only_stdlib_numpy_zenoh_and_the_icd():
    assert _outside("fsw/transport", "fsw.transport", "fsw.interface", "numpy", "zenoh") == []


def test_the_rule_checker_catches_a_violation(tmp_path, monkeypatch):
    # The checker must be able to fail: plant a bad import in a copy of the layout.
    pkg = tmp_path / "fsw"
    pkg.mkdir()
    (pkg / "bad.py").write_text("import sim.dynamics\nfrom ground import logger\n")
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    assert len(_violations("fsw", lambda n: _under(n, "fsw"))) == 2

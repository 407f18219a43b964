"""The import rule is the architecture (docs/architecture.md): checked on the source, not by convention.

``LAYERS`` is the layer table of docs/architecture.md as data: for each package, which navbank
packages it may import and which third-party distributions (the standard library is always
allowed). Besides the table, two rules keep onboard behaviour defined once:

* campaign and replay code call the FSW's own declaration and report code — an
  ``AnomalyReport`` is built only by ``fsw/core/telemetry.py`` (and the ICD's own examples);
* flight and ground code hold no argument parsing (``argparse`` lives in ``tools/``).
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NAVBANK = {"fsw", "sim", "ground", "tools"}
ANY = None  # any third-party library


SHARED_ASTRO = ("fsw.astro.constants", "fsw.astro.ephemeris", "fsw.astro.frames")
ONBOARD_MODELS = ("fsw.astro.time", "fsw.astro.earth", "fsw.astro.stations", "fsw.astro.moons", "fsw.astro.mars",
                  "fsw.astro.asteroids", "fsw.astro.tracking_stations")


@dataclass(frozen=True)
class Layer:
    package: str  # directory, e.g. "fsw/interface"
    navbank: tuple[str, ...]  # navbank modules it may import (prefixes)
    third_party: tuple[str, ...] | None  # top-level third-party modules it may import; ANY: no limit
    excluding: tuple[str, ...] = ()  # sub-packages with a layer of their own


LAYERS = (
    Layer("fsw/interface", ("fsw.interface",), ("numpy", "yaml", "msgspec")),
    Layer("fsw/transport", ("fsw.transport", "fsw.interface"), ("numpy", "zenoh")),
    Layer("fsw/astro", ("fsw.astro", "fsw.interface"), ANY),
    Layer("fsw", ("fsw",), ANY, excluding=("fsw/interface", "fsw/transport", "fsw/astro")),
    # the simulator flies its own truth models (sim/truth); of fsw.astro it shares only what is not
    # a model: nature's and defined constants, the DE421 data reader and rotation algebra
    Layer("sim", ("sim", "fsw.interface", "fsw.transport", *SHARED_ASTRO), ANY),
    Layer("ground", ("ground", "fsw"), ANY),
    Layer("tools", ("tools", "fsw", "sim", "ground"), ANY),
)


def _files(package: str, excluding: tuple[str, ...] = ()) -> list[Path]:
    skip = [ROOT / e for e in excluding]
    return [p for p in sorted((ROOT / package).rglob("*.py")) if not any(s in p.parents for s in skip)]


def _imports(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.lineno, node.module
            # `from fsw import transport` imports fsw.transport, not just fsw
            for alias in node.names:
                yield node.lineno, f"{node.module}.{alias.name}"


def _under(name: str, *prefixes: str) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def _violations(layer: Layer) -> list[str]:
    bad = []
    for path in _files(layer.package, layer.excluding):
        for line, name in _imports(path):
            top = name.split(".")[0]
            if top in NAVBANK:
                if name in NAVBANK:  # `from fsw import x` is judged by its member, fsw.x
                    continue
                ok = _under(name, *layer.navbank)
            elif top in sys.stdlib_module_names or top == "__future__":
                ok = True
            elif layer.third_party is ANY:
                ok = True
            else:
                ok = top in layer.third_party or name.split(".")[0] in layer.third_party
            if not ok:
                bad.append(f"{path.relative_to(ROOT)}:{line}: imports {name}")
    return sorted(set(bad))


@pytest.mark.parametrize("layer", LAYERS, ids=lambda layer: layer.package)
def test_layer_imports_only_what_the_layer_table_allows(layer):
    assert _violations(layer) == []


def test_the_layer_table_covers_every_package():
    covered = {layer.package for layer in LAYERS}
    for top in NAVBANK:
        assert top in covered
    for sub in (ROOT / "fsw").iterdir():
        if sub.is_dir() and (sub / "__init__.py").exists():
            rel = f"fsw/{sub.name}"
            owner = [layer for layer in LAYERS if rel == layer.package or (layer.package == "fsw" and rel not in
                     layer.excluding)]
            assert owner, rel


def _calls(path: Path, name: str) -> list[int]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            called = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None
            if called == name:
                out.append(node.lineno)
    return out


def test_anomaly_reports_are_built_only_by_the_fsw_telemetry_code():
    allowed = {ROOT / "fsw/core/telemetry.py", ROOT / "fsw/interface/examples.py"}
    bad = [f"{p.relative_to(ROOT)}:{line}" for top in sorted(NAVBANK) for p in _files(top) if p not in allowed
           for line in _calls(p, "AnomalyReport")]
    assert bad == []


def test_campaign_and_replay_code_call_the_fsw_declaration_and_report_code():
    worker = {name for _, name in _imports(ROOT / "tools/campaign/worker.py")}
    assert "fsw.core.telemetry.AnomalyReporter" in worker, "campaign monitors must replay through the FSW's reporter"
    rerun = {name for _, name in _imports(ROOT / "ground/replay/rerun.py")}
    assert any(_under(n, "fsw.core") for n in rerun), "the replay re-run must fly the FSW's own core"


def test_flight_and_ground_code_hold_no_argument_parsing():
    bad = [f"{p.relative_to(ROOT)}:{line}" for top in ("fsw", "ground", "sim") for p in _files(top)
           for line, name in _imports(p) if _under(name, "argparse")]
    assert bad == []


def test_the_rule_checker_catches_a_violation(tmp_path, monkeypatch):
    # The checker must be able to fail: plant bad imports in a copy of the layout.
    (tmp_path / "fsw" / "interface").mkdir(parents=True)
    (tmp_path / "fsw" / "bad.py").write_text("import sim.dynamics\nfrom ground import logger\n")
    (tmp_path / "fsw" / "interface" / "bad.py").write_text("import zenoh\nfrom fsw import filters\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    fsw_rest = next(layer for layer in LAYERS if layer.package == "fsw")
    assert len(_violations(fsw_rest)) == 2
    interface = next(layer for layer in LAYERS if layer.package == "fsw/interface")
    assert len(_violations(interface)) == 2  # zenoh, fsw.filters


def test_shared_astro_modules_hold_no_onboard_model():
    # what the simulator may share with the FSW must not itself reach an onboard model
    for mod in SHARED_ASTRO:
        path = ROOT / (mod.replace(".", "/") + ".py")
        reached = [name for _, name in _imports(path) if _under(name, *ONBOARD_MODELS)]
        assert reached == [], f"{mod} imports onboard models {reached}"
    assert set(ONBOARD_MODELS) | set(SHARED_ASTRO) == {
        f"fsw.astro.{p.stem}" for p in (ROOT / "fsw/astro").glob("*.py") if p.stem != "__init__"}


def test_the_simulator_may_not_fly_onboard_models(tmp_path, monkeypatch):
    (tmp_path / "sim").mkdir()
    (tmp_path / "sim" / "bad.py").write_text(
        "from fsw.astro.earth import itrs_to_gcrs_state\nfrom fsw.astro import moons\nimport fsw.astro.time\n"
        "from fsw.astro.constants import C_KM_S\nfrom fsw.astro.ephemeris import default_ephemeris\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    sim = next(layer for layer in LAYERS if layer.package == "sim")
    assert {v.split(": ")[1] for v in _violations(sim)} == {
        "imports fsw.astro", "imports fsw.astro.earth", "imports fsw.astro.earth.itrs_to_gcrs_state",
        "imports fsw.astro.moons", "imports fsw.astro.time"}

"""Expansion of a campaign file into runs: one fully resolved scenario per cell, one id per run.

Per cell the scenario is built as data, in this order (later wins): the scenario file, the
campaign's ``overrides``, the network variant (gating list, parameter changes, detector network,
calibration, the variant's own overrides), then the fault case's faults. The result is validated
once as a :class:`~tools.scenario.ScenarioConfig`, so a bad combination (a fault after the end of
a shortened run, an unknown gating parameter) is one line pointing into the campaign file.

A run's id is a hash of its resolved configuration and seed: re-running a campaign finds the
runs it already has, and editing a cell (another span, another sigma_w) gives its runs new ids
instead of silently reusing stale results.
"""

from __future__ import annotations

import copy
import hashlib
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fsw.fdir.config import DetectorConfig
from fsw.interface import typed
from fsw.interface.typed import DecodeError
from fsw.interface.yamlconfig import ConfigError, load_file
from sim.faults.presets import preset
from ground.report.row_types import Cell
from tools.campaign.plan_file import PlanFile, PlannedCell, PlannedRun
from tools.campaign.spec import FaultCase, LoadedCampaign, NetworkVariant
from tools.campaign.task import RunTask
from tools.scenario import ScenarioConfig, builtin_names, load_scenario


@dataclass
class CampaignPlan:
    name: str
    description: str
    tasks: list[RunTask]
    cells: list[Cell] = field(default_factory=list)

    def _planned_cell(self, cell: Cell) -> PlannedCell:
        t = next((t for t in self.tasks if t.cell == cell), None)
        return PlannedCell(scenario=cell.scenario, fault=cell.fault, variant=cell.variant, key=cell.key,
                           fault_class=t.fault_class if t else None, detector=t.detector if t else None)

    def plan_file(self) -> PlanFile:
        """What ``plan.json`` holds."""
        return PlanFile(name=self.name, description=self.description,
                        cells=tuple(self._planned_cell(c) for c in self.cells),
                        runs=tuple(PlannedRun(id=t.id, cell=t.cell.key, seed=t.seed) for t in self.tasks))


def run_id(scenario_data: dict, seed: int, monitors: dict | None = None) -> str:
    """Stable id of a run: the first 16 hex digits of SHA-256 over the canonical JSON of the
    resolved scenario and the seed (and the monitor calibrations, when there are any: they change
    the run's summary, not its flight)."""
    key: dict[str, Any] = {"scenario": scenario_data, "seed": int(seed)}
    if monitors:
        key["monitors"] = monitors
    blob = json.dumps(key, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _nested(key: str, value: Any) -> dict:
    out: Any = value
    for part in reversed(key.split(".")):
        if not part:
            raise ValueError(f"empty component in key {key!r}")
        out = {part: out}
    return out


def merge(data: dict, changes: dict[str, Any]) -> None:
    """Deep-merge ``changes`` (keys may be dotted paths) into ``data``; mappings merge, anything
    else (numbers, lists) replaces."""
    for key, value in changes.items():
        _merge_into(data, _nested(key, value))


def _merge_into(data: dict, changes: dict) -> None:
    for k, v in changes.items():
        if isinstance(v, dict) and isinstance(data.get(k), dict):
            _merge_into(data[k], v)
        else:
            data[k] = copy.deepcopy(v)


def _load_base(loaded: LoadedCampaign, ref: str, where: str) -> ScenarioConfig:
    path = Path(ref)
    if ref.endswith((".yaml", ".yml")) or (loaded.base_dir / path).is_file() or path.is_file():
        full = path if path.is_absolute() else loaded.base_dir / path
        if not full.is_file() and path.is_file():
            full = path
        return load_scenario(str(full))
    if ref not in builtin_names():
        raise loaded.error(where, "a built-in scenario (" + ", ".join(builtin_names()) + ") or a scenario file",
                           f"unknown name {ref!r}")
    return load_scenario(ref)


def _load_calibration(loaded: LoadedCampaign, ref: str) -> DetectorConfig:
    cal_path = Path(ref)
    return load_file(DetectorConfig, cal_path if cal_path.is_absolute() else loaded.base_dir / cal_path)


def _monitors(var: NetworkVariant, loaded: LoadedCampaign, where: str) -> dict[str, DetectorConfig]:
    out: dict[str, DetectorConfig] = {}
    for net, ref in var.monitors.items():
        cal = _load_calibration(loaded, ref)
        if cal.network != net:
            raise loaded.error(f"{where}.monitors.{net}", f"a calibration of network {net!r}",
                               f"{ref} calibrates {cal.network!r}")
        out[net] = cal
    return out


def _apply_variant(data: dict, var: NetworkVariant, loaded: LoadedCampaign, where: str) -> None:
    fsw = data["fsw"]
    if var.gating:
        fsw["gating"] = [g._typed_encode(False) for g in var.gating]
    for net, changes in var.params.items():
        entry = next((g for g in fsw["gating"] if g.get("network") == net), None)
        if entry is None:
            raise loaded.error(f"{where}.params.{net}", "a network of the gating list "
                               f"({', '.join(g.get('network', '?') for g in fsw['gating'])})", repr(net))
        entry.update(copy.deepcopy(changes))
    detector = var.detector
    if var.calibration is not None:
        cal = _load_calibration(loaded, var.calibration)
        fsw["detector"]["calibration"] = typed.encode(cal)
        if detector is None:
            detector = cal.network
    if detector is not None:
        if not any(g.get("network") == detector for g in fsw["gating"]):
            fsw["gating"].append({"network": detector})
        fsw["detector"]["network"] = detector
    for net in var.monitors:  # a monitor replays its network's weights: the network must run
        if not any(g.get("network") == net for g in fsw["gating"]):
            fsw["gating"].append({"network": net})
    merge(data, var.overrides)


def _faults(case: FaultCase, default_onset: float | None) -> tuple:
    if case.preset is not None:
        onset = case.onset_day if case.onset_day is not None else default_onset
        return preset(case.preset, onset_day=onset)
    return case.faults


def _cell_error(loaded: LoadedCampaign, bi: int, fi: int, vi: int, cell: Cell, exc: DecodeError,
                data: dict, var: NetworkVariant) -> ConfigError:
    m = re.match(r"fsw\.gating\[(\d+)\]", exc.path)
    if exc.path.startswith("sim.faults") or (exc.path == "sim" and "fault" in exc.got):
        where = f"matrix[{bi}].faults[{fi}]"
    elif m:
        k = int(m.group(1))
        net = data["fsw"]["gating"][k].get("network") if k < len(data["fsw"]["gating"]) else None
        where = f"matrix[{bi}].networks[{vi}]"
        if net in var.params:
            where += f".params.{net}"
        elif var.gating:
            where += f".gating[{k}]"
    elif exc.path.startswith("fsw.gating") or exc.path.startswith("fsw.detector"):
        where = f"matrix[{bi}].networks[{vi}]"
    elif loaded.config.overrides:
        where = "overrides"
    else:
        where = f"matrix[{bi}]"
    return loaded.error(where, f"a valid run for cell {cell.key} ({exc.path or '<scenario>'}: expected {exc.expected})",
                        exc.got)


def expand(loaded: LoadedCampaign, extract_weights: tuple[str, ...] | str = ()) -> CampaignPlan:
    """Every run of the campaign, cell by cell (block order, then scenario, fault, variant) and
    seed by seed. ``extract_weights`` (with the campaign's ``keep_weights``): networks whose weight
    histories every run stores."""
    cfg = loaded.config
    if isinstance(extract_weights, str):
        extract_weights = (extract_weights,)
    keep = tuple(dict.fromkeys((*cfg.keep_weights, *extract_weights)))
    tasks: list[RunTask] = []
    cells: list[Cell] = []
    seen: dict[str, Cell] = {}
    for bi, block in enumerate(cfg.matrix):
        for si, ref in enumerate(block.scenarios):
            base = _load_base(loaded, ref, f"matrix[{bi}].scenarios[{si}]")
            base_data = typed.encode(base)
            for fi, case in enumerate(block.faults):
                for vi, var in enumerate(block.networks):
                    cell = Cell(base.name, case.label, var.name)
                    data = copy.deepcopy(base_data)
                    try:
                        merge(data, cfg.overrides)
                    except ValueError as exc:
                        raise loaded.error("overrides", "dotted scenario keys", str(exc)) from None
                    _apply_variant(data, var, loaded, f"matrix[{bi}].networks[{vi}]")
                    monitors = _monitors(var, loaded, f"matrix[{bi}].networks[{vi}]")
                    for net in keep:  # a kept history needs its network to run
                        if not any(g.get("network") == net for g in data["fsw"]["gating"]):
                            data["fsw"]["gating"].append({"network": net})
                    data["sim"]["faults"] = [typed.encode(f) for f in _faults(case, cfg.onset_day)]
                    det_data = data["fsw"]["detector"]
                    cal_data = det_data.get("calibration")
                    if isinstance(cal_data, dict) and cal_data.get("network") != det_data.get("network", "chi2"):
                        # a calibration learned on another network's weights means nothing here
                        det_data["calibration"] = None
                    try:
                        scen = typed.decode(ScenarioConfig, data)
                    except DecodeError as exc:
                        raise _cell_error(loaded, bi, fi, vi, cell, exc, data, var) from None
                    det = scen.fsw.detector
                    calibrated = det.calibration is not None
                    final = typed.encode(scen)
                    fault_class = scen.sim.faults[0].fault_class if scen.sim.faults else "none"
                    bank = sorted(f.name for f in scen.fsw.bank.filters)
                    for net, mcal in monitors.items():
                        if sorted(mcal.filters) != bank:
                            raise loaded.error(f"matrix[{bi}].networks[{vi}].monitors.{net}",
                                               f"a calibration for the bank {bank} of cell {cell.key}",
                                               f"filters {list(mcal.filters)}")
                    monitor_data = {net: typed.encode(mcal) for net, mcal in monitors.items()}
                    if cell in cells:
                        raise loaded.error(f"matrix[{bi}]", "distinct cell labels (scenario names, fault "
                                           "cases, variants)", f"cell {cell.key!r} twice")
                    cells.append(cell)
                    for seed in cfg.seeds.seeds():
                        rid = run_id(final, seed, monitor_data)
                        if rid in seen:
                            raise loaded.error(f"matrix[{bi}]", "cells that differ in configuration",
                                               f"cells {seen[rid].key!r} and {cell.key!r} are the same runs")
                        seen[rid] = cell
                        tasks.append(RunTask(
                            id=rid, cell=cell, seed=seed, scenario=final,
                            fault_label=case.preset if case.preset is not None else case.label,
                            fault_class=fault_class, detector_network=det.network,
                            detector_calibrated=calibrated, span_days=scen.sim.span_days,
                            extract_weights=keep, keep_mcap=cfg.keep_mcap, monitors=monitor_data,
                        ))
    return CampaignPlan(cfg.name, cfg.description, tasks, cells)

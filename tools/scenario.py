"""Scenarios: the whole configuration of a run (simulator + flight software), built-ins, faults.

A scenario file has four parts: a name and description, the default seed, ``sim:`` (truth,
sensors, faults — :class:`sim.config.SimConfig`) and ``fsw:`` (bank, gating, detector, budget —
:class:`fsw.config.FswConfig`). Built-in scenarios are YAML files shipped in
``tools/scenarios/``; ``navbank scenarios --show NAME`` prints one in full.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from fsw.config import FswConfig, InitialState
from fsw.interface.typed import did_you_mean, spec
from fsw.interface.yamlconfig import ConfigError, dump_yaml, load_file, load_text
from sim.config import SimConfig
from sim.faults.presets import FAULT_PRESETS, preset
from sim.trajectories.design import initial_state as design_initial_state


@dataclass(frozen=True)
class ScenarioConfig:
    """A complete, reproducible description of a run (the seed may be overridden per run)."""

    name: str = spec(doc="scenario name")
    description: str = spec("", doc="one line shown by `navbank scenarios`")
    seed: int = spec(1, doc="default random seed (noise, dispersions, a-priori error draw)", ge=0)
    sim: SimConfig = spec(default_factory=SimConfig, doc="truth and sensor simulator")
    fsw: FswConfig = spec(default_factory=FswConfig, doc="flight software")

    def __post_init__(self) -> None:
        earth = self.sim.leo is not None
        if earth != (self.fsw.central_body == "earth"):
            raise ValueError("sim.leo (an Earth orbiter) and fsw.central_body: earth go together")


def builtin_names() -> list[str]:
    """Names of the built-in scenarios."""
    files = resources.files("tools").joinpath("scenarios")
    return sorted(p.name.removesuffix(".yaml") for p in files.iterdir() if p.name.endswith(".yaml"))


def builtin_text(name: str) -> str:
    path = resources.files("tools").joinpath("scenarios", f"{name}.yaml")
    if not path.is_file():
        raise ConfigError(name, None, "", "a built-in scenario (" + ", ".join(builtin_names()) + ") or a YAML file",
                          "unknown name" + did_you_mean(name, builtin_names()))
    return path.read_text(encoding="utf-8")


def load_scenario(name_or_path: str) -> ScenarioConfig:
    """A built-in scenario by name, or a scenario YAML file by path."""
    if name_or_path.endswith((".yaml", ".yml")) or Path(name_or_path).is_file():
        return load_file(ScenarioConfig, name_or_path)
    return load_text(ScenarioConfig, builtin_text(name_or_path), f"<built-in {name_or_path}>")


def with_fault(cfg: ScenarioConfig, fault: str | None, onset_day: float | None = None) -> ScenarioConfig:
    """Replace the scenario's faults by a preset (``None`` keeps them)."""
    if fault is None:
        return cfg
    if fault not in FAULT_PRESETS:
        raise ConfigError("--fault", None, "", "one of " + ", ".join(FAULT_PRESETS), repr(fault) + did_you_mean(fault, FAULT_PRESETS))
    if cfg.sim.leo is not None:
        raise ConfigError("--fault", None, "", "no fault: the Earth-orbit (leo) case has none", repr(fault))
    faults = preset(fault, onset_day=onset_day)
    return dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, faults=tuple(faults)))


def initial_state(cfg: ScenarioConfig, seed: int) -> InitialState:
    """The a-priori state uplinked to the FSW: the design trajectory's initial state plus one draw
    of the a-priori error of the bank's first filter (Lubey & Ely 2022 Table 1: 100 km, 0.1 m/s per axis).

    Drawn from its own generator so it never changes the simulator's noise draws."""
    if cfg.fsw.initial_state is not None:
        return cfg.fsw.initial_state
    if cfg.sim.leo is not None:
        # the Earth-orbit case: the a-priori is the planned injection state (the truth is that
        # plus the injection dispersion; Garhwal, Halder & Sinha's poor a-priori)
        from sim.scenarios.leo_injection import planned_state
        from sim.truth.earth import EarthOrientation
        from sim.truth.timescales import utc_iso_to_tdb

        t0 = utc_iso_to_tdb(cfg.sim.leo.epoch_utc)
        z = planned_state(cfg.sim.leo, t0, EarthOrientation(t0 - 600.0, t0 + 600.0))
        return InitialState(t_s=float(t0), position_km=tuple(float(v) for v in z[0:3]),
                            velocity_km_s=tuple(float(v) for v in z[3:6]))
    t0, x0 = design_initial_state(cfg.sim.trajectory, cfg.sim.forces)
    f0 = cfg.fsw.bank.filters[0]
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x0A1B]))
    dr = rng.normal(0.0, f0.position_sigma_km, 3)
    dv = rng.normal(0.0, f0.velocity_sigma_km_s, 3)
    return InitialState(t_s=float(t0), position_km=tuple(float(v) for v in x0[:3] + dr),
                        velocity_km_s=tuple(float(v) for v in x0[3:6] + dv))


def resolve(cfg: ScenarioConfig, seed: int | None = None) -> tuple[ScenarioConfig, int]:
    """The exact configuration of one run: seed fixed, FSW initial state filled in."""
    seed = cfg.seed if seed is None else int(seed)
    fsw = cfg.fsw.with_initial_state(initial_state(cfg, seed))
    return dataclasses.replace(cfg, seed=seed, fsw=fsw), seed


def to_yaml(cfg: ScenarioConfig, complete: bool = True) -> str:
    """YAML text of a scenario; ``complete`` writes every value, defaults included."""
    return dump_yaml(cfg, drop_defaults=not complete)


def load_text_scenario(text: str, name: str = "<string>") -> ScenarioConfig:
    """A scenario from YAML text (tests, scripts)."""
    return load_text(ScenarioConfig, text, name)

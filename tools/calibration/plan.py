"""Calibration plans: the procedure behind a set of shipped detector thresholds, as a file.

A plan fixes what ``navbank calibrate`` would otherwise take from its options — the scenario, the
networks, how many nominal runs on which seeds, the held-out runs that check the result, and the
detector's statistic, persistence and target — so that ``navbank calibrate --plan insight-approach``
re-derives the shipped thresholds exactly and a changed procedure is a reviewed change to a file.
Built-in plans live in ``tools/campaigns/calibrations/``.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Literal

from fsw.interface import typed
from fsw.interface.typed import spec
from fsw.interface.yamlconfig import ConfigError, load_file, load_text


@dataclass(frozen=True)
class CalibrationPlan:
    """How one scenario's detectors are calibrated and checked."""

    scenario: str = spec(doc="built-in scenario name or scenario file")
    networks: tuple[str, ...] = spec(doc="gating networks calibrated on the same nominal runs", max_items=16)
    seeds: int = spec(doc="nominal calibration runs", ge=1)
    base_seed: int = spec(doc="first calibration seed", ge=0)
    target_fa: float = spec(doc="false-alarm probability per run (or per segment)", gt=0.0, lt=1.0)
    holdout: int = spec(0, doc="held-out nominal runs that check the calibrated detectors", ge=0)
    holdout_base_seed: int | None = spec(None, doc="first held-out seed (default: right after the calibration seeds)",
                                         ge=0)
    warmup: int = spec(0, doc="batches ignored at the start of each run", ge=0)
    persistence: tuple[int, int] = spec((3, 5), doc="declare when K of the last N batches exceed the threshold")
    hold: int = spec(5, doc="batches below the clear threshold to clear", ge=1)
    statistic: Literal["mahalanobis", "max-z"] = spec("mahalanobis", doc="deviation statistic")
    segment_batches: int | None = spec(None, doc="false-alarm rate per segment of this many batches", ge=1)
    description: str = spec("", doc="what the plan calibrates, one line")

    def __post_init__(self) -> None:
        if not self.networks:
            raise ValueError("networks must not be empty")
        k, n = self.persistence
        if not 1 <= k <= n:
            raise ValueError("persistence [K, N] needs 1 <= K <= N")
        if self.holdout and self.holdout_seeds().start < self.calibration_seeds().stop \
                and self.calibration_seeds().start < self.holdout_seeds().stop:
            raise ValueError("the held-out seeds must not overlap the calibration seeds")

    def calibration_seeds(self) -> range:
        return range(self.base_seed, self.base_seed + self.seeds)

    def holdout_seeds(self) -> range:
        first = self.base_seed + self.seeds if self.holdout_base_seed is None else self.holdout_base_seed
        return range(first, first + self.holdout)


def builtin_dir():
    return resources.files("tools").joinpath("campaigns", "calibrations")


def builtin_names() -> list[str]:
    return sorted(p.name.removesuffix(".yaml") for p in builtin_dir().iterdir() if p.name.endswith(".yaml"))


def load_plan(name_or_path: str) -> CalibrationPlan:
    """A built-in plan by name, or a plan YAML file by path (``ConfigError`` names the bad key)."""
    path = Path(name_or_path)
    if name_or_path.endswith((".yaml", ".yml")) or path.is_file():
        return load_file(CalibrationPlan, path)
    res = builtin_dir().joinpath(f"{name_or_path}.yaml")
    if not res.is_file():
        raise ConfigError(name_or_path, None, "", "a built-in calibration plan (" + ", ".join(builtin_names())
                          + ") or a YAML file", "unknown name" + typed.did_you_mean(name_or_path, builtin_names()))
    return load_text(CalibrationPlan, res.read_text(encoding="utf-8"), f"<built-in calibration plan {name_or_path}>")

"""Configuration of one anomaly detector (one per gating network), as produced by calibration.

Everything a detector needs lives here: the nominal band of the network's weights (per-filter mean
and covariance learned from nominal runs, ``calibrate.py``), the declaration threshold chosen for
a target false-alarm rate, the persistence/hysteresis parameters, and the characterization
significance gates. The YAML functions go through :mod:`fsw.interface.yamlconfig`, so a bad file
is reported as one ``FILE:LINE: key.path: expected …, got …`` line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from fsw.interface.typed import spec
from fsw.interface.yamlconfig import dump_yaml, load_text

Statistic = Literal["mahalanobis", "max-z"]


@dataclass(frozen=True)
class DetectorConfig:
    """Calibrated trigger, hysteresis and characterization settings for one gating network."""

    network: str = spec(doc="Gating network whose weights this detector watches (e.g. 'chi2')")
    filters: tuple[str, ...] = spec(doc="Filter names, in the order of the nominal vectors below")
    nominal_mean: tuple[float, ...] = spec(doc="Mean weight of each filter on nominal runs")
    nominal_cov: tuple[tuple[float, ...], ...] = spec(
        doc="Covariance of the weights on nominal runs (before the spread floor is added)"
    )
    threshold: float = spec(doc="Declaration threshold on the detection statistic D", gt=0.0)
    clear_threshold: float = spec(doc="D must stay below this for `hold` batches to clear", gt=0.0)
    onset_reference: float = spec(
        doc="CUSUM reference value for the onset look-back: excursion accumulates D - reference", ge=0.0
    )
    statistic: Statistic = spec(
        "mahalanobis",
        doc="D = Mahalanobis distance of the weights from the nominal band, or max |z| over filters",
    )
    spread_floor: float = spec(
        1.0e-3, doc="Added to every filter's nominal standard deviation (pinned weights)", gt=0.0
    )
    persistence_k: int = spec(3, doc="Declare when k of the last n batches exceed the threshold", ge=1)
    persistence_n: int = spec(5, doc="Length n of the k-of-n persistence window", ge=1)
    hold: int = spec(5, doc="Consecutive batches below clear_threshold needed to clear", ge=1)
    warmup: int = spec(0, doc="Batches ignored after start or reset (gating-network transient)", ge=0)
    target_fa: float = spec(0.01, doc="Target false-alarm probability per run (or per segment)", gt=0.0, lt=1.0)
    segment_batches: int | None = spec(
        None, doc="If set, the false-alarm rate is per segment of this many batches instead of per run", ge=1
    )
    min_margin: float = spec(
        0.02, doc="Smallest preference margin (in weight) for the decision tree to name a class", ge=0.0
    )
    min_margin_z: float = spec(
        2.0, doc="Smallest preference margin in units of its nominal standard deviation", ge=0.0
    )

    def __post_init__(self) -> None:
        n = len(self.filters)
        if n < 2:
            raise ValueError("a detector needs at least two filters")
        if len(set(self.filters)) != n:
            raise ValueError("filter names must be unique")
        if len(self.nominal_mean) != n:
            raise ValueError(f"nominal_mean has {len(self.nominal_mean)} entries for {n} filters")
        cov = np.asarray(self.nominal_cov, dtype=float)
        if cov.shape != (n, n):
            raise ValueError(f"nominal_cov must be {n}x{n}, got {cov.shape}")
        if not np.all(np.isfinite(cov)) or not np.allclose(cov, cov.T, atol=1e-12):
            raise ValueError("nominal_cov must be finite and symmetric")
        if np.min(np.linalg.eigvalsh(cov)) < -1e-10:
            raise ValueError("nominal_cov must be positive semi-definite")
        if self.clear_threshold >= self.threshold:
            raise ValueError("clear_threshold must be below threshold (hysteresis)")
        if self.onset_reference >= self.threshold:
            raise ValueError("onset_reference must be below threshold")
        if self.persistence_k > self.persistence_n:
            raise ValueError("persistence_k must not exceed persistence_n")


def config_to_yaml(config: DetectorConfig) -> str:
    """YAML text of a detector configuration (every field written, defaults included)."""
    return dump_yaml(config, drop_defaults=False)


def config_from_yaml(text: str, file: str = "<string>") -> DetectorConfig:
    """Parse and validate a detector configuration (raises ``ConfigError`` with file and line)."""
    return load_text(DetectorConfig, text, file)

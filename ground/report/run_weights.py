"""A gating network's weight history over one run, as compact arrays: what campaigns keep in
``weights/<network>/<run id>.npz`` (``keep_weights``, ``navbank calibrate``) instead of the run's
~10^5 messages."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np


def _no_columns() -> np.ndarray:
    return np.zeros((0, 0))


@dataclass(frozen=True)
class RunWeights:
    """One network's FilterWeights of one run: filter names, batch epochs and indices, weights
    ``[batch, filter]``, per-filter batch statistics and (hierarchical networks) the top-level
    weight of each bank ``[batch, bank]``."""

    filters: tuple[str, ...]
    t_s: np.ndarray
    batch: np.ndarray
    weights: np.ndarray
    statistic: np.ndarray = field(default_factory=_no_columns)
    group_names: tuple[str, ...] = ()
    groups: np.ndarray = field(default_factory=_no_columns)

    @classmethod
    def empty(cls) -> "RunWeights":
        """The history of a network that published nothing."""
        return cls(filters=(), t_s=np.zeros(0), batch=np.zeros(0, dtype=np.int64), weights=_no_columns())

    def save(self, file: str | Path | BinaryIO) -> None:
        np.savez(file, filters=np.array(self.filters, dtype=str), t_s=self.t_s, batch=self.batch,
                 weights=self.weights, groups=self.groups, group_names=np.array(self.group_names, dtype=str),
                 statistic=self.statistic)

    @classmethod
    def load(cls, file: str | Path | BinaryIO) -> "RunWeights":
        """A stored history (files written before statistics and banks were kept load without them)."""
        with np.load(file, allow_pickle=False) as data:
            return cls(filters=tuple(str(f) for f in data["filters"]), t_s=data["t_s"], batch=data["batch"],
                       weights=data["weights"],
                       statistic=data["statistic"] if "statistic" in data.files else _no_columns(),
                       group_names=tuple(str(g) for g in data["group_names"]) if "group_names" in data.files else (),
                       groups=data["groups"] if "groups" in data.files else _no_columns())

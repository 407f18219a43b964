"""A filter's (or a combination's) estimate: state, covariance and the names of the states."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.interface.frozen import fast_init


@fast_init
@dataclass(frozen=True)
class StateEstimate:
    """An estimate in its filter's own state layout."""

    name: str
    t: float
    state_names: tuple[str, ...]
    x: np.ndarray
    P: np.ndarray

    @property
    def sigma(self) -> np.ndarray:
        # np.clip with only a lower bound is np.maximum; called directly, without clip's wrappers
        return np.sqrt(np.maximum(self.P.diagonal(), 0.0))


@fast_init
@dataclass(frozen=True)
class FilterEstimate(StateEstimate):
    """A navigation estimate: the state starts with Mars-centred position [km] and velocity [km/s]."""

    @property
    def position_km(self) -> np.ndarray:
        return self.x[0:3]

    @property
    def velocity_km_s(self) -> np.ndarray:
        return self.x[3:6]

    @property
    def position_sigma_km(self) -> float:
        """Root of the trace of the position covariance (RTPC, Lubey & Ely 2022 §4.2)."""
        # the three terms added left to right from 0.0, as numpy's trace adds them
        P = self.P
        return math.sqrt(max(0.0 + float(P[0, 0]) + float(P[1, 1]) + float(P[2, 2]), 0.0))

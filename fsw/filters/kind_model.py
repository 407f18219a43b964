"""What the EKF bank needs of a measurement kind: screening, prediction, extra noise.

The bank knows no kind by name. For each measurement it looks the kind up in the registry
(:mod:`fsw.filters.kinds`) and asks that kind's model to screen the message, to predict it with
every filter — h_ij(x̄_ij) and H̃_ij, the quantities of Lubey & Ely 2022 eq. 5 — and for any
variance the reported sigma leaves out. A model may also take the whole measurement step in one
compiled call where the step by step path costs more in calls than in arithmetic (a Doppler count).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from fsw.interface.kinds import KindDeclaration
from fsw.interface.messages import Measurement
from fsw.models.environment import Environment

if TYPE_CHECKING:  # the stack imports the filter configuration, which imports the registry
    from fsw.filters.ekf import EKFStack


class KindModel(Protocol):
    """The onboard model of one ICD measurement kind."""

    @property
    def declaration(self) -> KindDeclaration:
        """The ICD's declaration of the kind (name, dimension, unit)."""
        ...

    @property
    def family(self) -> str:
        """Measurement family (:mod:`fsw.fdir.families`) a filter processing the kind belongs to."""
        ...

    def screen(self, meas: Measurement, env: Environment) -> None:
        """Refuse, with :class:`fsw.filters.errors.MeasurementRejected`, what the model cannot use
        (value and sigma are screened already, for every kind alike)."""
        ...

    def predict(self, stack: EKFStack, meas: Measurement, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """h (N, m) and H (N, m, n) of the measurement for the stacked states x at epoch t."""
        ...

    def added_variance(self, stack: EKFStack, meas: Measurement) -> np.ndarray | None:
        """(N,) variance each filter adds to every component of R beyond the reported sigma, or None."""
        ...

    def step(self, stack: EKFStack, meas: Measurement, t1: float, value: np.ndarray, sigma: np.ndarray,
             scale: np.ndarray, does: np.ndarray, gate: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """The bank's whole filtering of one screened measurement — propagation to t1, prediction
        with every filter, R from ``sigma`` (m,) times the filters' ``scale`` (N,) and the added
        variance, the update of the filters that ``does`` under their ``gate`` (N,) (inf: none) —
        in one compiled call, with the results of those steps one by one; returns what
        :meth:`EKFStack.update` returns. None where the model has no such call or it does not
        apply: the bank then runs the steps (the stack may already be at t1)."""
        ...

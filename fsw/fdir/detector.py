"""Automatic anomaly trigger and characterization on a gating network's weights.

This is the "automated method for triggering an anomaly detection by the gating network" and the
"decision tree to characterize the anomaly using the filter weightings" that Lubey & Ely 2022 §5 leaves
as future work. After each gating batch the detector

1. computes D, the distance of the weights from the network's nominal band (``statistic.py``);
2. declares when k of the last n batches have D > threshold (``persistence.py``; the threshold is
   calibrated to a target false-alarm rate, ``calibrate.py``);
3. estimates the onset CUSUM-style: S_k = max(0, S_{k−1} + D_k − reference); the excursion began
   at the first batch after S was last zero (Page's change-time estimate);
4. characterizes the anomaly from the mean weights since onset (``characterize.py``);
5. clears with hysteresis once D < clear_threshold for ``hold`` consecutive batches, or at once on
   a telecommanded :meth:`AnomalyDetector.reset`.

Bad input raises :class:`FdirInputError` before any state changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np

from fsw.fdir.characterize import characterize
from fsw.fdir.config import DetectorConfig
from fsw.fdir.errors import FdirInputError
from fsw.fdir.families import FilterFamily, ordered_families
from fsw.fdir.persistence import KOfN
from fsw.fdir.statistic import NominalBand
from fsw.gating.base import WeightsUpdate
from fsw.interface.frozen import fast_init
from fsw.interface.messages import AnomalyClass

SUM_TOLERANCE = 1.0e-6


@fast_init
@dataclass(frozen=True)
class AnomalyState:
    """The detector's verdict after a batch (the FSW app maps it to the ICD AnomalyReport).

    ``confidence`` is the characterization confidence (0 while no anomaly is declared).
    ``evidence`` holds the latest weights, ``evidence_mean`` the mean weights since the onset
    (what the decision tree judged). ``statistic`` is None while the detector is not evaluating
    (warm-up after start/reset, fewer than two active filters). ``batch_statistic`` is the
    per-filter statistic the gating network reported with the weights, if any.
    """

    network: str
    t: float | None
    flag: bool
    anomaly_class: AnomalyClass
    confidence: float
    onset_t: float | None
    declared_t: float | None
    cleared_t: float | None
    statistic: float | None
    threshold: float
    evidence: dict[str, float] = field(default_factory=dict)
    evidence_mean: dict[str, float] = field(default_factory=dict)
    batch_statistic: dict[str, float] = field(default_factory=dict)


class AnomalyDetector:
    """Detector for one gating network; feed it every weight update of that network."""

    # the declaration in progress, (re)set by _rearm
    _flag: bool
    _declared_t: float | None
    _onset_t: float | None
    _cusum: float
    _sum_w: np.ndarray
    _count_w: int
    _below: int
    _window: KOfN
    _batches: int

    def __init__(self, config: DetectorConfig, families: Sequence[FilterFamily]):
        self.config = config
        self.families = ordered_families(families, config.filters)
        self._names = config.filters
        self._n = len(self._names)
        self._band = NominalBand.from_config(config)
        self._bands: dict[tuple[bool, ...], NominalBand] = {(True,) * self._n: self._band}
        self._orders: dict[tuple[str, ...], np.ndarray] = {}
        self._last_t: float | None = None
        self._cleared_t: float | None = None
        self._state = self._quiet_state(None, None, {}, {})
        self._rearm()

    # -- public ---------------------------------------------------------------------------------

    @property
    def state(self) -> AnomalyState:
        return self._state

    def reset(self) -> AnomalyState:
        """Telecommanded reset: clear any declaration and re-arm (warm-up restarts too)."""
        if self._flag:
            self._cleared_t = self._last_t
        self._rearm()
        self._state = self._quiet_state(self._last_t, None, self._state.evidence, {})
        return self._state

    def update(
        self,
        t: float,
        weights: np.ndarray | Sequence[float],
        filter_names: Sequence[str],
        active: np.ndarray | Sequence[bool] | None = None,
        batch_statistic: np.ndarray | Sequence[float] | None = None,
    ) -> AnomalyState:
        """Consume one gating batch: time tag, weights (in ``filter_names`` order), optionally the
        active mask and the per-filter statistic behind the weights (e.g. the batch chi-square
        G_k,i of Lubey & Ely 2022 eq. 6; reported as evidence only)."""
        t, w, mask, stat = self._validated(t, weights, filter_names, active, batch_statistic)
        self._last_t = t
        self._batches += 1
        evidence = {n: float(v) for n, v in zip(self._names, w)}
        stat_ev = {} if stat is None else {n: float(v) for n, v in zip(self._names, stat)}
        if self._batches <= self.config.warmup:
            self._state = self._current_state(t, None, evidence, stat_ev, mask)
            return self._state
        if mask.sum() < 2:
            # one active filter always has weight 1: nothing to judge, the verdict stands
            self._state = replace(self._state, t=t, statistic=None, evidence=evidence, batch_statistic=stat_ev)
            return self._state
        band = self._band_for(mask)
        d = float(band.deviation(w[mask]))
        if self._flag:
            self._accumulate(w)
            self._below = self._below + 1 if d < self.config.clear_threshold else 0
            if self._below >= self.config.hold:
                self._cleared_t = t
                self._rearm(keep_warmup=True)
        else:
            self._track_onset(t, d, w)
            if self._window.push(d > self.config.threshold):
                self._flag = True
                self._declared_t = t
                self._below = 0
        self._state = self._current_state(t, d, evidence, stat_ev, mask)
        return self._state

    def consume(self, update: WeightsUpdate, active: np.ndarray | Sequence[bool] | None = None) -> AnomalyState:
        """Consume a gating network's :class:`~fsw.gating.base.WeightsUpdate` (same as
        :meth:`update` with its time tag, filters, weights and per-filter statistic)."""
        if update.network != self.config.network:
            raise FdirInputError(f"update from network {update.network!r}, detector is for {self.config.network!r}")
        return self.update(update.t, update.weights, update.filters, active, update.statistic)

    # -- internals ------------------------------------------------------------------------------

    def _rearm(self, keep_warmup: bool = False) -> None:
        self._flag = False
        self._declared_t = None
        self._onset_t = None
        self._cusum = 0.0
        self._sum_w = np.zeros(self._n)
        self._count_w = 0
        self._below = 0
        self._window = KOfN(self.config.persistence_k, self.config.persistence_n)
        if not keep_warmup:
            self._batches = 0

    def _track_onset(self, t: float, d: float, w: np.ndarray) -> None:
        s = max(0.0, self._cusum + d - self.config.onset_reference)
        if s == 0.0:
            self._onset_t = None
            self._sum_w[:] = 0.0
            self._count_w = 0
        else:
            if self._cusum == 0.0 or self._onset_t is None:
                self._onset_t = t
                self._sum_w[:] = 0.0
                self._count_w = 0
            self._accumulate(w)
        self._cusum = s

    def _accumulate(self, w: np.ndarray) -> None:
        self._sum_w += w
        self._count_w += 1

    def _band_for(self, mask: np.ndarray) -> NominalBand:
        key = tuple(bool(m) for m in mask)
        if key not in self._bands:
            self._bands[key] = self._band.restricted(mask)
        return self._bands[key]

    def _quiet_state(self, t, d, evidence, stat_ev) -> AnomalyState:
        return AnomalyState(
            network=self.config.network, t=t, flag=False, anomaly_class="none", confidence=0.0,
            onset_t=None, declared_t=None, cleared_t=self._cleared_t, statistic=d,
            threshold=self.config.threshold, evidence=evidence, batch_statistic=stat_ev,
        )

    def _current_state(self, t, d, evidence, stat_ev, mask) -> AnomalyState:
        if not self._flag:
            return self._quiet_state(t, d, evidence, stat_ev)
        mean_w = self._sum_w / max(self._count_w, 1)
        sub = mean_w[mask]
        total = sub.sum()
        sub = sub / total if total > 0 else sub
        verdict = characterize(
            sub, self._band_for(mask), self.families, self.config.min_margin,
            self.config.min_margin_z, active=mask,
        )
        return AnomalyState(
            network=self.config.network, t=t, flag=True, anomaly_class=verdict.anomaly_class,  # type: ignore[arg-type]
            confidence=float(min(max(verdict.confidence, 0.0), 1.0)), onset_t=self._onset_t,
            declared_t=self._declared_t, cleared_t=self._cleared_t, statistic=d,
            threshold=self.config.threshold, evidence=evidence,
            evidence_mean={n: float(v) for n, v in zip(self._names, mean_w)}, batch_statistic=stat_ev,
        )

    def _order(self, filter_names: Sequence[str]) -> np.ndarray:
        key = tuple(filter_names)
        order = self._orders.get(key)
        if order is None:
            if len(key) != self._n or set(key) != set(self._names):
                raise FdirInputError(
                    f"filters {list(key)} do not match the detector's bank {list(self._names)}"
                )
            if len(set(key)) != len(key):
                raise FdirInputError("duplicate filter names in the update")
            pos = {n: i for i, n in enumerate(key)}
            order = np.array([pos[n] for n in self._names])
            self._orders[key] = order
        return order

    def _validated(self, t, weights, filter_names, active, batch_statistic):
        try:
            t = float(t)
        except (TypeError, ValueError):
            raise FdirInputError(f"time tag {t!r} is not a number") from None
        if not math.isfinite(t):
            raise FdirInputError("time tag must be finite")
        if self._last_t is not None and t < self._last_t:
            raise FdirInputError(f"time tag {t} precedes the previous update {self._last_t}")
        if isinstance(filter_names, str):
            raise FdirInputError("filter_names must be a sequence of names, not one string")
        order = self._order(filter_names)
        w = self._vector(weights, "weights")[order]
        if abs(w.sum() - 1.0) > SUM_TOLERANCE:
            raise FdirInputError(f"weights sum to {w.sum():.9g}, not 1")
        if active is None:
            mask = np.ones(self._n, dtype=bool)
        else:
            raw = np.asarray(active)
            if raw.shape != (self._n,) or raw.dtype != bool:
                raise FdirInputError(f"active must be {self._n} booleans")
            mask = raw[order]
        stat = None if batch_statistic is None else self._vector(batch_statistic, "batch_statistic")[order]
        return t, w, mask, stat

    def _vector(self, values, what: str) -> np.ndarray:
        try:
            v = np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            raise FdirInputError(f"{what} are not numbers") from None
        if v.shape != (self._n,):
            raise FdirInputError(f"{what} must have shape ({self._n},), got {v.shape}")
        if not np.all(np.isfinite(v)):
            raise FdirInputError(f"{what} contain NaN or infinity")
        return v

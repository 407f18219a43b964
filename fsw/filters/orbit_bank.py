"""A bank of Earth-centred 6-state EKFs for orbit determination just after injection
(Garhwal, Halder & Sinha): position and velocity in the GCRS, the FSW's own two-body + J2
dynamics (:mod:`fsw.models.earth_gravity`), ground-station range, range rate, azimuth and
elevation (:mod:`fsw.models.topocentric`), and per filter the process-noise mode of
:mod:`fsw.filters.adaptive_q` — fixed (a plain EKF), ``lsq-adaptive`` or ``fuzzy-adaptive`` —
so the paper's three filters fly the same measurements side by side.

Two ways in. :meth:`OrbitBank.process_epoch` updates jointly with all the measurements of one
epoch (every kind from every visible station); :meth:`OrbitBank.process` takes one ICD
measurement at a time (the flight software's pipeline) and updates sequentially. Either way the
adaptive window receives one state residual Δx̄ per epoch — the sum of that epoch's corrections,
handed over when the bank leaves the epoch — so the slope is fitted over distinct times as in
the paper. Joseph-form updates; the chi-square of each filter's pre-fit residual against its S
goes into a :class:`~fsw.filters.record.BankRecord`, which the gating networks consume unchanged.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from fsw.astro.tracking_stations import STATIONS, station_frame_gcrs
from fsw.filters.adaptive_q import AdaptiveQ, AdaptiveQConfig, AdaptiveQCounters
from fsw.filters.config import BankConfig
from fsw.filters.combine import best_index, normalised_weights, weighted_estimate
from fsw.filters.errors import MeasurementRejected, UnknownFilter
from fsw.filters import kinds
from fsw.filters.estimate import FilterEstimate
from fsw.filters.record import BankRecord
from fsw.interface.messages import Measurement
from fsw.models import earth_gravity, topocentric


@dataclass(frozen=True)
class OrbitFilterConfig:
    name: str
    process_noise: AdaptiveQConfig = AdaptiveQConfig()
    velocity_noise_psd_km2_s3: float = 0.0  # optional white acceleration (SNC) on every filter


STATE_NAMES: tuple[str, ...] = ("x", "y", "z", "vx", "vy", "vz")
#: The kinds the bank processes (every filter processes all of them): its registry's.
KINDS: tuple[str, ...] = kinds.ORBIT_KINDS


class OrbitBank:
    """N Earth-centred EKFs advanced together."""

    def __init__(self, filters: Sequence[OrbitFilterConfig], t0: float, x0: ArrayLike, sigma0: ArrayLike) -> None:
        """``sigma0``: a-priori 1-sigma per state, (6,) for every filter or (N, 6) per filter."""
        self.configs = tuple(filters)
        self.names = tuple(f.name for f in self.configs)
        n = len(self.configs)
        self.t = float(t0)
        self.x = np.tile(np.asarray(x0, dtype=float), (n, 1))
        sig = np.broadcast_to(np.asarray(sigma0, dtype=float), (n, 6))
        self.P = np.eye(6)[None] * (sig ** 2)[:, None, :]
        self.adaptive = [AdaptiveQ(f.process_noise) if f.process_noise.mode != "fixed" else None for f in self.configs]
        self.psd = np.array([f.velocity_noise_psd_km2_s3 for f in self.configs])
        self.seq = 0
        self.active = np.ones(n, dtype=bool)
        self.processed_count = 0
        self.rejected: Counter[str] = Counter()
        self.state_names = STATE_NAMES
        self._epoch_prior: np.ndarray | None = None  # x before the first update of the open epoch

    @classmethod
    def from_config(cls, config: BankConfig, t0: float, position_km: ArrayLike, velocity_km_s: ArrayLike) -> "OrbitBank":
        """The bank of a scenario's ``fsw.bank``: per filter its name, process-noise mode, white
        acceleration and a-priori sigmas (the Mars bank's other settings have no meaning here)."""
        filters = [OrbitFilterConfig(f.name, f.process_noise, f.velocity_noise_psd_km2_s3) for f in config.filters]
        sigma0 = np.array([[f.position_sigma_km] * 3 + [f.velocity_sigma_km_s] * 3 for f in config.filters])
        return cls(filters, t0, np.concatenate([np.asarray(position_km, float), np.asarray(velocity_km_s, float)]), sigma0)

    # -- the Bank protocol ----------------------------------------------------------------------
    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise UnknownFilter(name) from None

    def set_enabled(self, name: str, enabled: bool) -> None:
        """A disabled filter is still propagated and predicts, but does not update."""
        self.active[self.index(name)] = bool(enabled)

    def processes(self, name: str, kind: str) -> bool:
        self.index(name)
        return kind in KINDS

    def position_sigma_km(self, name: str) -> float:
        i = self.index(name)
        return float(math.sqrt(np.trace(self.P[i, 0:3, 0:3])))

    def estimates(self, weights: ArrayLike | None = None) -> dict[str, FilterEstimate]:
        out = {n: FilterEstimate(n, self.t, STATE_NAMES, self.x[i].copy(), self.P[i].copy())
               for i, n in enumerate(self.names)}
        if weights is None:
            return out
        w = normalised_weights(np.asarray(weights, dtype=float), self.active)
        used = w > 0.0
        x_opt, P_opt = weighted_estimate(self.x[used], self.P[used], w[used])
        out["combined"] = FilterEstimate("combined", self.t, STATE_NAMES, x_opt, P_opt)
        out["best"] = out[self.names[best_index(w, self.active)]]
        return out

    def adaptive_lp_cost(self) -> float:
        return float(sum(aq.declared_cost() for aq, on in zip(self.adaptive, self.active) if aq is not None and on))

    def adaptive_counts(self) -> dict[str, int]:
        total = AdaptiveQCounters()
        present = False
        for aq in self.adaptive:
            if aq is not None:
                total.add(aq.counters)
                present = True
        return total.as_counts() if present else {}

    def process(self, meas: Measurement) -> BankRecord:
        """One ICD measurement: screened, the bank propagated to it, a sequential update of the
        enabled filters (:class:`~fsw.filters.errors.MeasurementRejected` before any change)."""
        try:
            y = self._screen(meas)
        except MeasurementRejected as exc:
            self.rejected[exc.reason] += 1
            raise
        self.propagate_to(max(float(meas.t_s), self.t))
        if self._epoch_prior is None:
            self._epoch_prior = self.x.copy()
        rec = self._update([meas], y, self.active.copy())
        self.processed_count += 1
        return BankRecord(t=float(meas.t_s), seq=int(meas.seq), kind=meas.kind, filters=self.names,
                          residual=rec[0], S=rec[1], chi2=rec[2], processed=self.active.copy(),
                          active=self.active.copy())

    def _screen(self, meas: Measurement) -> np.ndarray:
        if meas.kind not in KINDS:
            raise MeasurementRejected("unknown_kind", f"the Earth-orbit bank has no model for {meas.kind!r}")
        if meas.source not in STATIONS:
            raise MeasurementRejected("unknown_source", f"unknown tracking station {meas.source!r}")
        if len(meas.value) != 1 or len(meas.sigma) != 1:
            raise MeasurementRejected("bad_dimension", f"a {meas.kind} measurement has one component")
        v, sg = float(meas.value[0]), float(meas.sigma[0])
        if not (math.isfinite(v) and math.isfinite(sg) and math.isfinite(meas.t_s)):
            raise MeasurementRejected("non_finite", "non-finite time tag, value or sigma")
        if not sg > 0.0:
            raise MeasurementRejected("bad_sigma", "sigma must be > 0")
        if float(meas.t_s) < self.t - 1e-4:
            raise MeasurementRejected("out_of_order", f"time tag {meas.t_s} is before the bank epoch {self.t}")
        return np.array([v])

    def _close_epoch(self) -> None:
        """Hand the open epoch's summed correction to the adaptive windows."""
        if self._epoch_prior is None:
            return
        for i, aq in enumerate(self.adaptive):
            if aq is not None and self.active[i]:
                aq.add(self.t, self.x[i] - self._epoch_prior[i])
        self._epoch_prior = None

    def propagate_to(self, t: float) -> None:
        dt = float(t) - self.t
        if dt == 0.0:
            return
        self._close_epoch()
        self.x, phi = earth_gravity.propagate(self.x, dt)
        self.P = phi @ self.P @ np.swapaxes(phi, -1, -2)
        h = abs(dt)
        for i, aq in enumerate(self.adaptive):
            if aq is not None:
                self.P[i] += np.diag(aq.q_diagonal(dt))
            q = self.psd[i]
            if q > 0.0:
                self.P[i, 0:3, 0:3] += q * h ** 3 / 3 * np.eye(3)
                self.P[i, 0:3, 3:6] += q * h ** 2 / 2 * np.eye(3)
                self.P[i, 3:6, 0:3] += q * h ** 2 / 2 * np.eye(3)
                self.P[i, 3:6, 3:6] += q * h * np.eye(3)
        self.P = 0.5 * (self.P + np.swapaxes(self.P, -1, -2))
        self.t = float(t)

    def predict(self, meas: Sequence[Measurement], x: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """h (N, m) and H (N, m, 6) of the epoch's measurements (one component each, in order)."""
        x = self.x if x is None else x
        N = x.shape[0]
        h = np.empty((N, len(meas)))
        H = np.empty((N, len(meas), 6))
        frames: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for k, m in enumerate(meas):
            if m.source not in frames:
                r_s, v_s, enu = station_frame_gcrs(m.source, self.t)
                hs, Hs = topocentric.predict(x[:, 0:3], x[:, 3:6], np.repeat(r_s, N, 0), np.repeat(v_s, N, 0),
                                             np.repeat(enu, N, 0))
                frames[m.source] = (hs, Hs)
            hs, Hs = frames[m.source]
            c = kinds.ORBIT_REGISTRY[m.kind].component
            h[:, k] = hs[:, c]
            H[:, k] = Hs[:, c]
        return h, H

    def process_epoch(self, meas: Sequence[Measurement]) -> BankRecord:
        """Propagate to the epoch of ``meas`` (all one time tag) and update every filter jointly."""
        if not meas or any(m.t_s != meas[0].t_s for m in meas):
            raise ValueError("one epoch's measurements, all with one time tag")
        self.propagate_to(meas[0].t_s)
        self._epoch_prior = self.x.copy()
        y = np.array([m.value[0] for m in meas])
        res, S, chi2 = self._update(meas, y, self.active.copy())
        names = tuple(m.kind for m in meas)
        self._close_epoch()
        rec = BankRecord(t=self.t, seq=self.seq, kind="+".join(dict.fromkeys(names)), filters=self.names,
                         residual=res, S=S, chi2=chi2, processed=self.active.copy(), active=self.active.copy())
        self.seq += 1
        return rec

    def _update(self, meas: Sequence[Measurement], y: np.ndarray, does: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Joseph-form update of the filters where ``does``; (pre-fit residual, S, chi-square)."""
        h, H = self.predict(meas)
        res = y[None, :] - h
        for k, m in enumerate(meas):
            if kinds.ORBIT_REGISTRY[m.kind].wrap:
                res[:, k] = (res[:, k] + math.pi) % (2.0 * math.pi) - math.pi
        R = np.diag([m.sigma[0] ** 2 for m in meas])
        Ht = np.swapaxes(H, -1, -2)
        S = H @ self.P @ Ht + R
        S_inv = np.linalg.inv(S)
        chi2 = np.einsum("ni,nij,nj->n", res, S_inv, res)
        K = self.P @ Ht @ S_inv
        IKH = np.eye(6) - K @ H
        x_new = self.x + np.einsum("nij,nj->ni", K, res)
        P_new = IKH @ self.P @ np.swapaxes(IKH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
        self.x = np.where(does[:, None], x_new, self.x)
        self.P = np.where(does[:, None, None], P_new, self.P)
        return res, S, chi2

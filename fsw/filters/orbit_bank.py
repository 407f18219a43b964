"""A bank of Earth-centred 6-state EKFs for orbit determination just after injection
(Garhwal, Halder & Sinha): position and velocity in the GCRS, the FSW's own two-body + J2
dynamics (:mod:`fsw.models.earth_gravity`), ground-station range, range rate, azimuth and
elevation (:mod:`fsw.models.topocentric`), and per filter the process-noise mode of
:mod:`fsw.filters.adaptive_q` — fixed (a plain EKF), ``lsq-adaptive`` or ``fuzzy-adaptive`` —
so the paper's three filters fly the same measurements side by side.

The measurements of one epoch (every kind from every visible station) are one joint update, so
each update gives one state residual Δx̄ = x⁺ − x⁻ to the adaptive window at distinct epochs.
Joseph-form update; the chi-square of each filter's pre-fit residual against its S goes into a
:class:`~fsw.filters.record.BankRecord`, which the gating networks consume unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fsw.astro.tracking_stations import station_frame_gcrs
from fsw.filters.adaptive_q import AdaptiveQ, AdaptiveQConfig
from fsw.filters.record import BankRecord
from fsw.interface.messages import Measurement
from fsw.models import earth_gravity, topocentric


@dataclass(frozen=True)
class OrbitFilterConfig:
    name: str
    process_noise: AdaptiveQConfig = AdaptiveQConfig()
    velocity_noise_psd_km2_s3: float = 0.0  # optional white acceleration (SNC) on every filter


class OrbitBank:
    """N Earth-centred EKFs advanced together."""

    def __init__(self, filters: Sequence[OrbitFilterConfig], t0: float, x0: np.ndarray, sigma0: np.ndarray) -> None:
        self.configs = tuple(filters)
        self.names = tuple(f.name for f in self.configs)
        n = len(self.configs)
        self.t = float(t0)
        self.x = np.tile(np.asarray(x0, dtype=float), (n, 1))
        self.P = np.tile(np.diag(np.asarray(sigma0, dtype=float) ** 2), (n, 1, 1))
        self.adaptive = [AdaptiveQ(f.process_noise) if f.process_noise.mode != "fixed" else None for f in self.configs]
        self.psd = np.array([f.velocity_noise_psd_km2_s3 for f in self.configs])
        self.seq = 0

    def propagate_to(self, t: float) -> None:
        dt = float(t) - self.t
        if dt == 0.0:
            return
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
            c = topocentric.COMPONENTS.index(m.kind)
            h[:, k] = hs[:, c]
            H[:, k] = Hs[:, c]
        return h, H

    def process_epoch(self, meas: Sequence[Measurement]) -> BankRecord:
        """Propagate to the epoch of ``meas`` (all one time tag) and update every filter jointly."""
        if not meas or any(m.t_s != meas[0].t_s for m in meas):
            raise ValueError("one epoch's measurements, all with one time tag")
        self.propagate_to(meas[0].t_s)
        h, H = self.predict(meas)
        y = np.array([m.value[0] for m in meas])
        kinds = tuple(m.kind for m in meas)
        res = topocentric.wrap_residual(y[None, :] - h, kinds)
        R = np.diag([m.sigma[0] ** 2 for m in meas])
        Ht = np.swapaxes(H, -1, -2)
        S = H @ self.P @ Ht + R
        K = self.P @ Ht @ np.linalg.inv(S)
        chi2 = np.einsum("ni,nij,nj->n", res, np.linalg.inv(S), res)
        x_prior = self.x.copy()
        self.x = self.x + np.einsum("nij,nj->ni", K, res)
        IKH = np.eye(6) - K @ H
        self.P = IKH @ self.P @ np.swapaxes(IKH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
        for i, aq in enumerate(self.adaptive):
            if aq is not None:
                aq.add(self.t, self.x[i] - x_prior[i])
        rec = BankRecord(t=self.t, seq=self.seq, kind="+".join(dict.fromkeys(kinds)), filters=self.names,
                         residual=res, S=S, chi2=chi2, processed=np.ones(len(self.names), bool))
        self.seq += 1
        return rec

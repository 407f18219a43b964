"""The detection statistic D: how far a weight vector sits from the network's nominal band.

Lubey & Ely 2022 §3.2/§4.2 reads an anomaly from the chi-square network's weights leaving equality
(1/N each); the Magill network is nowhere near equal on nominal runs (it prefers the fused
filter), so the band is learned per network from nominal runs: a mean vector mu and a covariance
C of the weights. Each filter's standard deviation gets a floor ``s0`` (C_reg = C + s0^2 I) so a
weight pinned near 0 or 1 does not produce an infinite z-score, and so C_reg is invertible even
though the weights sum to one (C 1 = 0; the deviation w - mu has no component along 1, so the
regularisation never distorts the distance).

Two statistics:

* ``mahalanobis``: D = sqrt((w - mu)^T C_reg^-1 (w - mu)), which uses the correlation the
  sum-to-one constraint forces between filters;
* ``max-z``: D = max_i |w_i - mu_i| / sqrt(C_reg,ii), the largest per-filter excursion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.fdir.config import DetectorConfig


@dataclass(frozen=True)
class NominalBand:
    """Nominal mean and regularised covariance of a network's weights, and the distance D to it."""

    mean: np.ndarray
    cov: np.ndarray
    kind: str = "mahalanobis"

    def __post_init__(self) -> None:
        if self.kind not in ("mahalanobis", "max-z"):
            raise ValueError(f"unknown statistic {self.kind!r}")
        object.__setattr__(self, "_cov_inv", np.linalg.inv(self.cov))
        object.__setattr__(self, "_sigma", np.sqrt(np.diag(self.cov)))

    @classmethod
    def from_config(cls, config: DetectorConfig) -> "NominalBand":
        n = len(config.filters)
        cov = np.asarray(config.nominal_cov, dtype=float) + config.spread_floor**2 * np.eye(n)
        return cls(np.asarray(config.nominal_mean, dtype=float), cov, config.statistic)

    @classmethod
    def from_samples(cls, weights: np.ndarray, spread_floor: float, kind: str = "mahalanobis") -> "NominalBand":
        """Band from pooled nominal weight samples, shape (K, N)."""
        w = np.asarray(weights, dtype=float)
        cov = np.atleast_2d(np.cov(w, rowvar=False, ddof=1))
        return cls(w.mean(axis=0), cov + spread_floor**2 * np.eye(w.shape[1]), kind)

    @property
    def sigma(self) -> np.ndarray:
        """Regularised per-filter standard deviation."""
        return self._sigma  # type: ignore[attr-defined]

    def deviation(self, weights: np.ndarray) -> np.ndarray:
        """D for each weight vector; ``weights`` has shape (..., N), the result shape (...)."""
        d = np.asarray(weights, dtype=float) - self.mean
        if self.kind == "max-z":
            return np.max(np.abs(d) / self.sigma, axis=-1)
        q = np.einsum("...i,ij,...j->...", d, self._cov_inv, d)  # type: ignore[attr-defined]
        return np.sqrt(np.maximum(q, 0.0))

    def contrast_sigma(self, a: np.ndarray) -> float:
        """Nominal standard deviation of the linear contrast a^T w (for preference margins)."""
        return float(np.sqrt(max(a @ self.cov @ a, 0.0)))

    def restricted(self, active: np.ndarray) -> "NominalBand":
        """Band over the active filters only, renormalised as the gating networks renormalise
        weights when a filter is disabled (mean scaled by 1/s, covariance by 1/s^2, s = sum of the
        active nominal means). An approximation: the threshold was calibrated on the full bank."""
        mask = np.asarray(active, dtype=bool)
        s = float(self.mean[mask].sum())
        if s <= 0.0:
            s = 1.0
        return NominalBand(self.mean[mask] / s, self.cov[np.ix_(mask, mask)] / s**2, self.kind)

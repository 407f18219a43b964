"""Residual-correlation hypothesis testing (Hanlon & Maybeck 2000 §II.B, Hanlon & Maybeck 2000, eqs. 18–22).

A mis-modeled periodic input — e.g. attitude-thruster firings at a known cadence that one filter
does not model — leaves a sinusoid at the firing frequency in that filter's residuals. Its
*power at that frequency* is a far more sensitive statistic than the residual magnitude. Each
filter k is a hypothesis; for each filter this network

1. normalises each residual component by its predicted standard deviation,
   ε_c = z̄_c / √S_cc (so every component has unit variance under the filter's own hypothesis);
2. keeps the last N normalised residuals (the window) and evaluates the periodogram of each
   component at the configured frequencies f (eq. 20, the squared N-point Fourier transform,
   which is eq. 19 when cross-correlations between components are neglected as in Hanlon & Maybeck 2000):
       ψ_{k,c}(f; t_i) = (1/N) |Σ_{n=0}^{N−1} ε_{k,c}(t_{i−n}) exp(−j2π f τ_{i−n})|²,
   with τ the sample index (``time_base = "sample"``, f in cycles per sample, Hanlon & Maybeck's (2000)
   normalised frequency) or the time tag in seconds (``"time-tag"``, f in Hz — a direct
   Fourier sum, which stays exact for the irregular sampling of deep-space tracking);
3. forms the residual of the statistic r_kψ = ψ_k − ψ̄_k and its covariance A_kψ under
   hypothesis k (the conditional mean and covariance of Hanlon & Maybeck 2000 §II.B.2), and scores
   q_ψ = r_kψᵀ A_kψ⁻¹ r_kψ (eq. 22) inside the Gaussian density of eq. 21;
4. updates the hypothesis probabilities with the MMAE rule (eq. 17) in the log domain, with the
   Hanlon & Maybeck 2000 lower bound on the probabilities.

Two choices decide how often the hypothesis test is fooled in nominal operation:

* ``update_every`` (M): the probabilities are updated on every M-th record once the window is full
  ("propagating several time samples before updating", one of the hypothesis-test modifications
  Hanlon & Maybeck 2000 §II.B.2 list). Successive windows share N − M samples, so with M = 1 every
  residual enters the product of eq. 17 about N times and a random excursion of ψ moves the
  probabilities N times as far as its evidence warrants; with M = N the windows are disjoint and,
  under the true hypothesis, independent, and eq. 17 is the likelihood of the data it claims to be.
* ``density``: ``"gaussian"`` is eq. 21 as the paper writes it. Under hypothesis k the normalised
  residuals are white, so for a frequency away from 0 and Nyquist each component of ψ is an
  exponential variable of mean 1 (χ²₂/2) — the paper saw ψ "more chi-squared distributed" in the
  no-failure case. ``"exponential"`` uses that exact density, ln f = −Σ_d ψ_d/ψ̄_d − ln ψ̄_d (ψ̄ = 1,
  or the learned mean), whose penalty grows linearly rather than quadratically with the excess
  power, so the exponential tail of a correct filter's ψ is not mistaken for a failure signature.
  It is exact for consecutive samples (``time_base = "sample"``) at frequencies that are multiples
  of 1/N, close to it elsewhere away from 0 and Nyquist, and an approximation for irregular time tags.
  The statistic reported is then q = 2 Σ_d ψ_d/ψ̄_d (χ²_{2d} under the hypothesis).

Conditional mean and covariance (``calibration``):

* ``"analytic"`` — under hypothesis k the normalised residuals are white with unit variance, so
  for any sample times E[ψ] = 1 (the "floor" of Hanlon & Maybeck 2000 Fig. 5) and, writing C_f, S_f for the
  cosine and sine sums, Cov(ψ_f, ψ_g) = 2 [Cov(C_f,C_g)² + Cov(S_f,S_g)² + Cov(C_f,S_g)² +
  Cov(S_f,C_g)²] / N² with Cov(C_f, C_g) = Σ_n cos θ_fn cos θ_gn etc. (Isserlis' theorem; = 1 on
  the diagonal for uniform sampling away from 0 and Nyquist). Components are taken independent.
* ``"learn"`` — sample mean and covariance of each filter's ψ over the first
  ``calibration_count`` windows (Hanlon & Maybeck 2000 used 400 samples), assumed to be nominal operation;
  no weights are produced until then.

Records of other measurement kinds than ``kind`` (if set) are ignored. Updates are produced for
every record once the window is full (and the calibration done).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from fsw.filters.record import BankRecord
from fsw.gating.base import (
    GatingInputError,
    GatingNetwork,
    InvalidParameterError,
    WeightsUpdate,
    apply_lower_bound,
    log_normalize,
    reenter_probabilities,
)
from fsw.interface.typed import spec


@dataclass(frozen=True)
class ResidualCorrelationParams:
    """Parameters of the residual-correlation (periodogram) hypothesis-testing network."""

    window: int = spec(100, doc="N: residual samples in the periodogram window (Hanlon & Maybeck 2000 used 100)", ge=2)
    frequencies: tuple[float, ...] = spec(
        (0.02,), doc="frequencies f of the known excitation (cycles/sample or Hz, see time_base)", ge=0.0
    )
    time_base: Literal["sample", "time-tag"] = spec(
        "sample", doc="phase reference: sample index (f in cycles/sample) or time tag (f in Hz)"
    )
    kind: str | None = spec(None, doc="measurement kind whose residuals are used; None: every record")
    calibration: Literal["analytic", "learn"] = spec(
        "analytic", doc="conditional mean/covariance of ψ: white-residual theory or learned from a nominal span"
    )
    calibration_count: int = spec(400, doc="windows of nominal operation used by calibration = 'learn'", ge=2)
    update_every: int = spec(
        1, doc="M: update the probabilities on every M-th record once the window is full (M = window: disjoint windows)",
        ge=1,
    )
    density: Literal["gaussian", "exponential"] = spec(
        "gaussian", doc="density of ψ under each hypothesis: eq. 21's Gaussian or the exact exponential of white residuals"
    )
    lower_bound: float | None = spec(
        1e-3, doc="floor on each hypothesis probability (Hanlon & Maybeck 2000 lower bounding); None: no floor", gt=0.0, lt=1.0
    )


def periodogram(eps: np.ndarray, tau: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    """Hanlon & Maybeck 2000 eq. 20 per component: eps (W, ..., m) samples at phases τ (W,) → (..., m, F)."""
    theta = 2.0 * np.pi * np.outer(tau - tau[0], frequencies)  # (W, F)
    x = np.tensordot(np.exp(-1j * theta), eps, axes=([0], [0]))  # (F, ..., m)
    power = (x.real**2 + x.imag**2) / len(tau)
    return np.moveaxis(power, 0, -1)


def white_noise_covariance(tau: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    """Exact covariance (F, F) of the eq. 20 periodogram of unit-variance white Gaussian samples
    taken at phases τ (see the module docstring)."""
    theta = 2.0 * np.pi * np.outer(tau - tau[0], frequencies)
    c, s = np.cos(theta), np.sin(theta)
    cc, ss, cs = c.T @ c, s.T @ s, c.T @ s
    return 2.0 * (cc**2 + ss**2 + cs**2 + cs.T**2) / len(tau) ** 2


class ResidualCorrelationNetwork(GatingNetwork):
    """Hanlon & Maybeck 2000 residual-correlation Kalman filter bank hypothesis tester (per-measurement)."""

    name = "residual-correlation"
    params_type = ResidualCorrelationParams

    def _check_params(self, params: ResidualCorrelationParams) -> None:
        if not params.frequencies:
            raise InvalidParameterError("residual-correlation needs at least one frequency")

    def _params_changed(self, old: ResidualCorrelationParams, new: ResidualCorrelationParams) -> None:
        structural = ("window", "frequencies", "time_base", "kind", "calibration", "calibration_count")
        if any(getattr(old, f) != getattr(new, f) for f in structural):
            self._clear_window()
            self._clear_calibration()

    def _clear_window(self) -> None:
        self._eps: np.ndarray | None = None
        self._tau = np.zeros(self.params.window)
        self._filled = 0
        self._next = 0
        self._samples = 0

    def _clear_calibration(self) -> None:
        self._cal_sum: np.ndarray | None = None
        self._cal_outer: np.ndarray | None = None
        self._cal_n = 0
        self._mean: np.ndarray | None = None
        self._cov: np.ndarray | None = None
        self._model: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def _reset(self) -> None:
        # Reset restarts the hypothesis test; the window and a learned calibration (a model of
        # nominal operation) are kept.
        if not hasattr(self, "_eps"):
            self._clear_window()
            self._clear_calibration()
        n_active = max(int(np.count_nonzero(self._active)), 1)
        self._logp = np.where(self._active, -np.log(n_active), -np.inf)
        self._count = 0

    def recalibrate(self) -> None:
        """Forget the learned nominal statistics and learn them again from the next windows."""
        self._clear_calibration()

    def _weights(self) -> np.ndarray:
        return np.exp(self._logp)

    def _activation_changed(self, old: np.ndarray, new: np.ndarray) -> None:
        p = reenter_probabilities(np.exp(self._logp), old, new)
        with np.errstate(divide="ignore"):
            self._logp = np.log(p)
        self._logp[new] = np.maximum(self._logp[new], np.log(np.finfo(float).tiny))

    def _push(self, record: BankRecord) -> None:
        res = np.asarray(record.residual, dtype=float)
        sd = np.sqrt(np.diagonal(np.asarray(record.S, dtype=float), axis1=1, axis2=2))
        if np.any(sd <= 0.0):
            raise GatingInputError(f"non-positive innovation variance in record seq={record.seq}")
        eps = res / sd
        if self._eps is None or self._eps.shape[1:] != eps.shape:
            if self._eps is not None and self._filled:
                raise GatingInputError(
                    f"residual dimension changed from {self._eps.shape[2]} to {eps.shape[1]}; "
                    "set 'kind' to test one measurement type"
                )
            self._eps = np.zeros((self.params.window,) + eps.shape)
        tau = float(record.t) if self.params.time_base == "time-tag" else float(self._samples)
        self._eps[self._next] = eps
        self._tau[self._next] = tau
        self._next = (self._next + 1) % self.params.window
        self._filled = min(self._filled + 1, self.params.window)
        self._samples += 1

    def statistic(self) -> np.ndarray | None:
        """ψ_k for every filter, (N, m·F) (components major), or None before the window is full."""
        if self._eps is None or self._filled < self.params.window:
            return None
        # The sum of eq. 20 does not depend on the order of the ring buffer.
        psi = periodogram(self._eps, self._tau, np.asarray(self.params.frequencies))
        return psi.reshape(len(self.filters), -1)

    def _nominal(self, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(mean (N, d), inverse covariance (N, d, d), log-determinant (N,)) of ψ under each
        filter's own hypothesis."""
        if self.params.calibration == "learn":
            if self._model is None:
                mean, cov = self._mean, self._cov
                if mean is None or cov is None:
                    raise GatingInputError("the learned nominal model is used before its calibration is complete")
                self._model = (mean, np.linalg.inv(cov), np.linalg.slogdet(cov)[1])
            return self._model
        if self._model is not None and self._model[0].shape[1] == m * len(self.params.frequencies):
            return self._model
        n_f, n_freq = len(self.filters), len(self.params.frequencies)
        block = white_noise_covariance(self._tau, np.asarray(self.params.frequencies))
        block_inv = np.linalg.inv(block)
        logdet = m * np.linalg.slogdet(block)[1]
        cov_inv = np.kron(np.eye(m), block_inv) if m > 1 else block_inv
        model = (np.ones((n_f, m * n_freq)), np.broadcast_to(cov_inv, (n_f,) + cov_inv.shape), np.full(n_f, logdet))
        if self.params.time_base == "sample":
            # ψ is invariant to a shift of the phase origin, so with a full window of consecutive
            # samples its white-noise covariance never changes: compute it once.
            self._model = model
        return model

    def _learn(self, psi: np.ndarray) -> bool:
        """Accumulate nominal statistics; True once the calibration is complete."""
        if self._mean is not None:
            return True
        if self._cal_sum is None:
            self._cal_sum = np.zeros(psi.shape)
            self._cal_outer = np.zeros(psi.shape + (psi.shape[1],))
        self._cal_sum += psi
        self._cal_outer += psi[:, :, None] * psi[:, None, :]
        self._cal_n += 1
        if self._cal_n < self.params.calibration_count:
            return False
        n = self._cal_n
        mean = self._cal_sum / n
        cov = (self._cal_outer - n * mean[:, :, None] * mean[:, None, :]) / (n - 1)
        d = psi.shape[1]
        ridge = 1e-9 * np.trace(cov, axis1=1, axis2=2) / d + 1e-12
        self._mean = mean
        self._cov = cov + ridge[:, None, None] * np.eye(d)
        return True

    def _update(self, record: BankRecord, active: np.ndarray) -> WeightsUpdate | None:
        if self.params.kind is not None and record.kind != self.params.kind:
            return None
        self._push(record)
        psi = self.statistic()
        if psi is None:
            return None
        if self.params.calibration == "learn" and not self._learn(psi):
            return None
        if (self._samples - self.params.window) % self.params.update_every:
            return None
        mean, cov_inv, logdet = self._nominal(record.n)
        if self.params.density == "exponential":
            ratio = psi / mean
            q = 2.0 * ratio.sum(axis=1)
            loglik = -0.5 * q - np.log(mean).sum(axis=1)
        else:
            r = psi - mean
            q = np.einsum("kd,kde,ke->k", r, cov_inv, r)  # Hanlon & Maybeck 2000 eq. 22
            loglik = -0.5 * (q + logdet + r.shape[1] * np.log(2.0 * np.pi))  # eq. 21
        logp = log_normalize(self._logp + np.where(active, loglik, 0.0), active)  # eq. 17
        self._logp = apply_lower_bound(logp, active, self.params.lower_bound)
        update = self._make_update(record, self._count, self._weights(), statistic=q)
        self._count += 1
        return update

    def _state_extra(self) -> dict[str, Any]:
        return {
            "measurements": self._samples,
            "window_filled": self._filled,
            "calibrated": self.params.calibration == "analytic" or self._mean is not None,
            "calibration_windows": self._cal_n,
        }

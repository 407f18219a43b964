"""Magill's Bayesian filter-bank weights (Lubey & Ely 2022 eqs. 1–4, Chaer et al. 1997 eqs. 7–8), in the log domain.

Each filter i is a hypothesis α_i; with Gaussian residuals (Lubey & Ely 2022 eq. 4)

    f(y_k | α_i) = (2π)^{−n/2} |S_ik|^{−1/2} exp(−½ z̄_ikᵀ S_ik⁻¹ z̄_ik),

the posterior probabilities obey the sequential Bayes rule (Lubey & Ely 2022 eq. 3, Chaer et al. 1997 eqs. 7–8)

    p_k,i = f(y_k | α_i) p_{k−1},i / Σ_j f(y_k | α_j) p_{k−1},j,   p_0,i = f(α_i) (uniform by default).

Chaer et al. 1997 §III notes that evaluating the product Π_k f(y_k | α_i) of eq. 7 directly underflows
(§V.C: after 168 measurements of Experiment 3). Here the recursion is carried on log p and
normalised with log-sum-exp after every measurement, so the log-probabilities stay bounded (the largest is 0) and
nothing underflows however long the sequence; a hypothesis can only reach probability exp(−∞)
by an infinite amount of evidence. :func:`direct_product_weights` evaluates the literal product
form for validation (it shows where that form fails).

Normalising constant. Chaer et al. 1997 writes the density of eqs. 7 and 13 with the scalar normaliser
(2π|W_k|)^{−1/2} (eq. 22 confirms the reading: −ln f = ½(rᵀW⁻¹r + ln 2π|W|)), although the tracking
example's measurement is a 2-vector, whose density has (2π)^{−n/2}|W|^{−1/2}. The two differ by the
constant ((n−1)/2) ln 2π per measurement, the same for every filter, so it cancels in eq. 8 (and in
eq. 16 of the mixture of experts): the networks use the true n-variate density. It does change where
the *literal product* underflows, because every factor is larger by (2π)^{(n−1)/2}:
:func:`chaer1997_log_density` is the paper's form. On Experiment 3 (Table III, 5 × 100, float64 with
gradual underflow, 200 runs) the product dies after measurement 169 (165–173) with the paper's
normaliser — Chaer et al. 1997 reports 168 — and after 142 (139–145) with the n-variate one. (Reading the
printed 1/(√(2π)|W|) literally, with |W| not square-rooted, gives 128 and contradicts eq. 22.)

Switching (Chaer et al. 1997 §V.C reports that Magill switches to KF 2 "only after measurement 110", i.e.
10 after the change). Magill never forgets: after segment 1 KF 1 leads KF 2 by ~105 nat (1.06 nat
per measurement in steady state plus the start-up transient) and segment 2 takes that back at
~5.6 nat per measurement. Over 300 runs of Experiment 3 KF 2 takes the largest weight a median 21
measurements after the change (10–90 %: 13–32); 8 % of runs switch within 10, and in exactly those
runs the paper-normalised product underflows after measurement 165–170. The paper's single run is
consistent with the model as one such realisation, not with its median. Later changes are not
followed at all without a lower bound (the lead by then is hundreds of nats).

Optional lower bound (Hanlon & Maybeck 2000 §II.B.2, "lower bounding of the conditional probabilities"):
after each update, probabilities below ``lower_bound`` are raised to it (the others share the
rest), so the bank can switch to another filter in a bounded time after a regime change instead
of having to undo all the evidence accumulated since the start — Magill never forgets otherwise.

All measurements are used, processed or not (Lubey & Ely 2022 §2: this is what penalises filters that
only process a subset of the data types).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from fsw.filters.record import BankRecord
from fsw.gating.base import (
    GatingInputError,
    GatingNetwork,
    InvalidParameterError,
    WeightsUpdate,
    apply_lower_bound,
    log_normalize,
)
from fsw.interface.typed import spec
from fsw.kernels import on_first_call
from fsw.kernels.codes import MAGILL_NOT_POSITIVE_DEFINITE, MAGILL_UNHANDLED_DIMENSION

magill_update = on_first_call(globals(), "magill_update", "fsw.kernels.magill")


@dataclass(frozen=True)
class MagillParams:
    """Parameters of the Magill (MMAE) network."""

    lower_bound: float | None = spec(
        None, doc="floor on each filter's probability (Hanlon & Maybeck 2000 lower bounding); None: no floor", gt=0.0, lt=1.0
    )
    prior: tuple[float, ...] = spec((), doc="a-priori probabilities f(α_i), bank order; empty: uniform 1/N")


#: ln 2π of the Gaussian normaliser, computed as numpy computes it
LOG_2PI = float(np.log(2.0 * np.pi))


def gaussian_log_likelihood(record: BankRecord) -> np.ndarray:
    """ln f(y_j | α_i) of Lubey & Ely 2022 eq. 4 for every filter; rejects a non-positive-definite S."""
    n = record.n
    if n == 1:
        # A scalar measurement (range, Doppler): |S| is S itself. slogdet of a 1×1 matrix takes
        # the C library's log of it, as math.log does, so this is slogdet's result to the bit
        # without its per-call cost.
        variances = record.S.ravel().tolist()
        if min(variances) <= 0.0:
            raise GatingInputError(f"innovation covariance not positive definite in record seq={record.seq}")
        norm = LOG_2PI  # n · ln 2π with n = 1
        return np.array([-0.5 * (c + math.log(v) + norm) for c, v in zip(record.chi2.tolist(), variances)])
    if n == 2:
        # An image's [sample, line] (the other kind a bank sees every day): slogdet's LU of a
        # 2 × 2 matrix written out, in its operations (see _logdet_2x2)
        out = []
        for c, S in zip(record.chi2.tolist(), record.S.tolist()):
            logdet = _logdet_2x2(S[0][0], S[0][1], S[1][0], S[1][1])
            if logdet is None:
                raise GatingInputError(f"innovation covariance not positive definite in record seq={record.seq}")
            out.append(-0.5 * (c + logdet + 2 * LOG_2PI))
        return np.array(out)
    sign, logdet = np.linalg.slogdet(np.asarray(record.S, dtype=float))
    if np.any(sign <= 0.0):
        raise GatingInputError(f"innovation covariance not positive definite in record seq={record.seq}")
    return -0.5 * (np.asarray(record.chi2, dtype=float) + logdet + n * np.log(2.0 * np.pi))


def _logdet_2x2(a: float, b: float, c: float, d: float) -> float | None:
    """ln |det [[a, b], [c, d]]| as ``np.linalg.slogdet`` computes it — LU with partial pivoting,
    the multiplier formed with the pivot's reciprocal (as LAPACK's getrf scales the column), the
    logs of the pivots' magnitudes added — or None where its sign is not positive (not positive
    definite). ``tests/test_gating_magill.py`` holds the two equal to the bit."""
    if abs(c) > abs(a):  # rows swapped: the determinant changes sign
        p, r = c, 1.0 / c
        u = b - (a * r) * d
        sign = -1.0
    else:
        if a == 0.0:
            return None
        p, r = a, 1.0 / a
        u = d - (c * r) * b
        sign = 1.0
    # the sign of the determinant, from the signs alone (a product of the pivots could underflow)
    if u == 0.0 or ((p > 0.0) == (u > 0.0)) != (sign > 0.0):
        return None
    return math.log(abs(p)) + math.log(abs(u))


def chaer1997_log_density(record: BankRecord) -> np.ndarray:
    """ln f(z_k | α_i) with Chaer et al.'s (1997) printed normaliser (eqs. 7, 13, 22): −½(rᵀW⁻¹r + ln 2π|W|).

    Equals :func:`gaussian_log_likelihood` + ((n−1)/2) ln 2π: the same weights (the constant cancels
    in eqs. 8 and 16), but the absolute scale the paper's product form underflows with."""
    return gaussian_log_likelihood(record) + 0.5 * (record.n - 1) * np.log(2.0 * np.pi)


def direct_product_weights(loglik: np.ndarray, prior: np.ndarray | None = None) -> tuple[np.ndarray, int | None]:
    """The literal product form of Chaer et al. 1997 eqs. 7–8 in double precision, for validation.

    ``loglik`` (K, N) holds ln f(y_k | α_i) (use :func:`chaer1997_log_density` for the paper's
    absolute scale). The conditional densities p(z*_k | α_i) =
    Π_{m≤k} f(y_m | α_i) are accumulated as products of exp(ln f) and normalised with the prior.
    Returns the (K, N) weights (NaN once every product has underflowed to zero) and the 0-based
    index of the first measurement after which that happened (None if it never did).
    """
    loglik = np.asarray(loglik, dtype=float)
    n_f = loglik.shape[1]
    prior = np.full(n_f, 1.0 / n_f) if prior is None else np.asarray(prior, dtype=float)
    with np.errstate(under="ignore", invalid="ignore", over="ignore"):
        products = np.cumprod(np.exp(loglik), axis=0) * prior
        total = products.sum(axis=1)
        weights = products / total[:, None]
    dead = np.flatnonzero(~(total > 0.0))
    return weights, (int(dead[0]) if dead.size else None)


class MagillNetwork(GatingNetwork):
    """Log-domain Magill weights with an optional probability floor (per-measurement network)."""

    __slots__ = ("_logp", "_count")  # slotted: see fsw.executive.FrameExecutive

    name = "magill"
    params_type = MagillParams

    def _check_params(self, params: MagillParams) -> None:
        if params.prior:
            prior = np.asarray(params.prior, dtype=float)
            if prior.shape != (len(self.filters),):
                raise InvalidParameterError(f"prior needs {len(self.filters)} values, got {prior.size}")
            if np.any(prior <= 0.0) or abs(prior.sum() - 1.0) > 1e-9:
                raise InvalidParameterError("prior probabilities must be positive and sum to 1")

    def _log_prior(self, mask: np.ndarray) -> np.ndarray:
        n_f = len(self.filters)
        prior = np.asarray(self.params.prior, dtype=float) if self.params.prior else np.full(n_f, 1.0 / n_f)
        return log_normalize(np.log(prior), mask)

    def _reset(self) -> None:
        self._logp = self._log_prior(self._active)
        self._count = 0

    def _weights(self) -> np.ndarray:
        return np.exp(self._logp)

    @property
    def log_weights(self) -> np.ndarray:
        """ln p_k,i (−inf for disabled filters); finite for every active filter."""
        return self._logp.copy()

    def _activation_changed(self, old: np.ndarray, new: np.ndarray) -> None:
        kept = old & new
        entering = new & ~old
        n_active = int(np.count_nonzero(new))
        if not np.any(kept):
            self._logp = log_normalize(np.zeros(len(self.filters)), new)
            return
        logp = np.full(len(self.filters), -np.inf)
        logp[kept] = log_normalize(self._logp, kept)[kept] + np.log1p(-np.count_nonzero(entering) / n_active)
        logp[entering] = -np.log(n_active)
        self._logp = logp

    def _step(self, loglik: np.ndarray, mask: np.ndarray) -> None:
        evidence = loglik if False not in mask.tolist() else np.where(mask, loglik, 0.0)
        logp = log_normalize(self._logp + evidence, mask)
        self._logp = apply_lower_bound(logp, mask, self.params.lower_bound)

    def _update(self, record: BankRecord, active: np.ndarray) -> WeightsUpdate:
        # one compiled call for the measurements of one or two components (every kind a bank
        # sees), the Python form for larger ones; the lower bound applies to either's result
        n_f = len(self.filters)
        loglik, logp, weights = np.empty(n_f), np.empty(n_f), np.empty(n_f)
        status = magill_update(np.ascontiguousarray(record.chi2, dtype=float),
                               np.ascontiguousarray(record.S, dtype=float), active, self._logp, LOG_2PI,
                               loglik, logp, weights)
        if status == MAGILL_NOT_POSITIVE_DEFINITE:
            raise GatingInputError(f"innovation covariance not positive definite in record seq={record.seq}")
        if status == MAGILL_UNHANDLED_DIMENSION:
            loglik = gaussian_log_likelihood(record)
            self._step(loglik, active)
            weights = self._weights()
        elif self.params.lower_bound is not None:
            self._logp = apply_lower_bound(logp, active, self.params.lower_bound)
            weights = self._weights()
        else:
            self._logp = logp
        # every branch leaves ``weights`` a new array of this update's own (what _make_update
        # copies to): passed as it is, by position (one update per measurement)
        update = WeightsUpdate(self.name, float(record.t), int(record.seq), self._count, self.filters, weights, loglik)
        self._count += 1
        return update

    def update_block(self, loglik: np.ndarray) -> np.ndarray:
        """Apply K measurements given directly as log-likelihoods (K, N); returns the (K, N)
        weights after each. Same recursion as :meth:`update`, vectorised over K when there is
        no lower bound (for long replays and bulk validation)."""
        loglik = np.asarray(loglik, dtype=float)
        if loglik.ndim != 2 or loglik.shape[1] != len(self.filters):
            raise GatingInputError(f"log-likelihoods must have shape (K, {len(self.filters)}), got {loglik.shape}")
        if not np.all(np.isfinite(loglik)):
            raise GatingInputError("non-finite log-likelihood")
        mask = self._active
        out = np.zeros(loglik.shape)
        if self.params.lower_bound is None:
            # Cumulative sums can grow large over long blocks; do them in chunks so the running
            # total stays small relative to float64 resolution.
            for start in range(0, len(loglik), 4096):
                chunk = np.where(mask, loglik[start:start + 4096], 0.0)
                cum = self._logp + np.cumsum(chunk, axis=0)
                cum[:, ~mask] = -np.inf
                top = np.max(cum, axis=1, keepdims=True)
                logp = cum - (top + np.log(np.sum(np.exp(cum - top), axis=1, keepdims=True)))
                out[start:start + len(chunk)] = np.exp(logp)
                self._logp = logp[-1].copy()
        else:
            for k in range(len(loglik)):
                self._step(loglik[k], mask)
                out[k] = np.exp(self._logp)
        self._count += len(loglik)
        self._updates += len(loglik)
        return out

    def _state_extra(self) -> dict[str, Any]:
        return {"measurements": self._count, "log_weights": [float(v) for v in self._logp]}

"""Mixture-of-experts softmax gating network trained online (Chaer et al. 1997 eqs. 11–20).

Each filter i is an expert with a gating cell of weight vector a_i. For the input feature vector
φ = φ(record):

    u_i = a_iᵀ φ,                 g_i = exp(u_i) / Σ_j exp(u_j)               (eqs. 11–12)
    f_i = f(z_k | α_i)            (Gaussian residual density, eq. 13)
    h_i = f_i g_i / Σ_j f_j g_j   (a-posteriori probability, eq. 16)
    a_i ← a_i + η (h_i − g_i) φ   (gradient ascent on l = ln Σ f_i g_i, eqs. 15–20)

Everything is done with log-densities and log-sum-exp, so h never underflows however peaked the
likelihoods are.

Input features φ. Chaer et al. 1997 eq. 12 sets u_i = zᵀa_i with the raw measurement z_k as input, and
eq. 20 updates a_i along z_k. Here the default is the constant φ = [1] ("constant"): u_i = a_i is
then a learned log-prior per filter, the gate is the same for every input, and the only thing that
moves it is filter performance through (h_i − g_i). That is what Lubey & Ely 2022 §2 asks of a gating
network for anomaly detection, and it is the reading under which the paper's switching experiment
(§V.C) works at all. Measured on Chaer et al.'s (1997) tracking example (``sim.scenarios.chaer_tracking``, tests in
``tests/test_gating_moe.py``) with the literal φ = z_k:

* the effective step is η|z_k|² ≥ 10⁴ η (the velocity alone is 100 m/s), so within the first few
  measurements the losing logits are tens to hundreds of nats down; h_i − g_i =
  g_i(f_i/Σ_j f_j g_j − 1) is then negligible and the gate is practically frozen;
* which filter it freezes on is decided by the start-up transient (P₀⁻ = 1000 I, a 100 m/s velocity
  error), not by the data: with the Table I bank and a truth equal to KF 1, η = 0.1 freezes on KF 3
  by the fourth measurement in 10 of 10 runs; on Experiment 3 (η = 0.1, 1 or 7, 20 runs) the top filter changes at most
  three times in 500 measurements and the matching filter is on top 20 % of the time (one segment's
  worth), against 73 % with φ = [1] at η = 1;
* a linear-domain softmax of logits that size (10⁴–10¹⁰) overflows e^709, so the paper's smooth
  weight histories cannot have come from eq. 12 with unscaled z as printed.

The literal form stays available through ``feature_map`` (:func:`table_feature_map` serves a table
of inputs by measurement sequence number, e.g. the measurements of a replayed run; a bank record
does not carry the measurement value itself). ``features = "kind"`` appends a one-hot of the
measurement kind (from ``kinds``) to the constant, so filters can become experts per data type;
any callable ``feature_map`` whose first component is the constant 1 keeps the re-entry rule below
exact.

Behaviour on Chaer et al. 1997 §V with φ = [1] (the paper's reported numbers in brackets; details and the
reasons in ``sim.scenarios.chaer_tracking``):

* the learning is additive with a fading memory (§III): the winning logit lead grows only like
  ln k, so a regime change is undone in a bounded number of measurements, unlike Magill;
* Experiment 3, first change (60 runs): at η = 1 KF 1's weight starts to fall at once (below 0.9
  of its pre-change value a median 4 measurements after the change) and KF 2 takes the largest
  weight a median 10 after it [gating "switches after measurement 103"]; Magill needs a median 19
  [110]. Once its switch starts Magill reaches 0.9 on KF 2 within ~2 measurements, the gate at
  η = 1 takes a median 41 more, at η = 7 1.5 (top weight after a median 3) [§V.C: Magill assigns
  unity faster; "when η = 7.0, the gating network converges as fast as the Magill algorithm"];
* Experiments 1–2: the time to select KF 3 scales with η. The Table I/II filters KF 2, 4, 5 are
  within 0.02–0.05 nat per measurement of KF 3 (steady-state expected log-likelihoods), so even the
  exact Bayesian posterior (Magill) needs ~100–300 measurements (KF 3 at 0.73–0.82 after 100, 1.0
  after 300), and this additive rule, whose step is η g_i(f_i/f̄ − 1), is slower still: KF 3's
  weight after 100/300/1000 measurements is 0.28/0.51/0.74 (Exp. 1) and 0.30/0.47/0.45 (Exp. 2) at
  η = 1, 0.85/0.97 after 100/300 at η = 7, and stays below 0.3 for 1000 at η = 0.1 (medians of 5
  runs) [paper: "quite rapid" at η = 0.1 and 1.0]. That part of Chaer et al. 1997 does not reproduce with
  a bounded input; with the literal φ = z it looks "rapid" only because the gate freezes at once.

A disabled filter is left out of the softmax (g = 0, no learning). When it is enabled again its
constant component is set so that, with the other features at zero, its share is 1/N_active.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Sequence
from typing import Any, Callable, Literal

import numpy as np

from fsw.filters.record import BankRecord
from fsw.gating.base import GatingInputError, GatingNetwork, InvalidParameterError, WeightsUpdate, log_normalize
from fsw.gating.magill import gaussian_log_likelihood
from fsw.interface.typed import spec

FeatureMap = Callable[[BankRecord], np.ndarray]


@dataclass(frozen=True)
class MoeParams:
    """Parameters of the mixture-of-experts gating network."""

    eta: float = spec(1.0, doc="learning rate η of the gradient ascent (Chaer et al. 1997 eq. 20)", gt=0.0)
    features: Literal["constant", "kind"] = spec(
        "constant", doc="input features φ: constant 1 (pure performance learner) or constant + one-hot kind"
    )
    kinds: tuple[str, ...] = spec((), doc="measurement kinds of the one-hot features (features = 'kind')")


def feature_vector(record: BankRecord, features: str, kinds: tuple[str, ...]) -> np.ndarray:
    """φ(record) for the built-in feature sets; the first component is always the constant 1."""
    if features == "constant":
        return np.ones(1)
    phi = np.zeros(1 + len(kinds))
    phi[0] = 1.0
    if record.kind in kinds:
        phi[1 + kinds.index(record.kind)] = 1.0
    return phi


def table_feature_map(table: np.ndarray, bias: bool = False) -> tuple[FeatureMap, int]:
    """A feature map serving row ``record.seq`` of ``table`` (K, d) — e.g. the measurement values
    z_k of a replayed run, the input of Chaer et al. 1997 eq. 12 — optionally prefixed by a constant 1.

    Returns ``(feature_map, feature_dim)`` for :class:`MoeNetwork`. A record whose sequence
    number is outside the table raises :class:`GatingInputError`."""
    values = np.asarray(table, dtype=float)
    if values.ndim != 2 or values.shape[0] < 1 or not np.all(np.isfinite(values)):
        raise InvalidParameterError(f"feature table must be a finite (K, d) array, got shape {values.shape}")
    if bias:
        values = np.column_stack((np.ones(len(values)), values))

    def feature_map(record: BankRecord) -> np.ndarray:
        if not 0 <= record.seq < len(values):
            raise GatingInputError(f"no input features for measurement seq={record.seq} (table has {len(values)})")
        return values[record.seq]

    return feature_map, int(values.shape[1])


def reentry_bias(a: np.ndarray, kept: np.ndarray, entering: np.ndarray) -> np.ndarray:
    """Gate weight vectors after filters re-enter: entering rows copy the kept rows' mean, with
    the constant component set so that each has share 1/N_active at φ = [1, 0, …]."""
    a = a.copy()
    n_active = int(np.count_nonzero(kept | entering))
    n_enter = int(np.count_nonzero(entering))
    bias = a[kept, 0]
    top = bias.max()
    lse = top + np.log(np.sum(np.exp(bias - top)))
    share = 1.0 / n_active
    a[entering] = a[kept].mean(axis=0)
    a[entering, 0] = lse + np.log(share) - np.log1p(-n_enter * share)
    return a


class MoeNetwork(GatingNetwork):
    """Chaer et al. 1997 softmax gating network with online gradient ascent (per-measurement network)."""

    name = "moe"
    params_type = MoeParams

    def __init__(self, filter_names: Sequence[str], params: Any = None, feature_map: FeatureMap | None = None, feature_dim: int | None = None):
        if (feature_map is None) != (feature_dim is None):
            raise InvalidParameterError("feature_map and feature_dim go together")
        self._feature_map = feature_map
        self._feature_dim = feature_dim
        super().__init__(filter_names, params)

    def _dim(self) -> int:
        if self._feature_dim is not None:
            return int(self._feature_dim)
        return 1 if self.params.features == "constant" else 1 + len(self.params.kinds)

    def _phi(self, record: BankRecord) -> np.ndarray:
        if self._feature_map is None:
            return feature_vector(record, self.params.features, self.params.kinds)
        phi = np.asarray(self._feature_map(record), dtype=float)
        if phi.shape != (self._dim(),) or not np.all(np.isfinite(phi)):
            raise GatingInputError(f"feature map returned {phi.shape}, expected finite ({self._dim()},)")
        return phi

    def _reset(self) -> None:
        # Equal (zero) cell weights: no filter favoured initially (Chaer et al. 1998 §III).
        self._a = np.zeros((len(self.filters), self._dim()))
        self._g = log_normalize(np.zeros(len(self.filters)), self._active)
        self._count = 0

    def _params_changed(self, old: MoeParams, new: MoeParams) -> None:
        if (old.features, old.kinds) != (new.features, new.kinds):
            self._reset()

    def _weights(self) -> np.ndarray:
        return np.exp(self._g)

    @property
    def cell_weights(self) -> np.ndarray:
        """The gate's weight vectors a_i, (N, d)."""
        return self._a.copy()

    def _activation_changed(self, old: np.ndarray, new: np.ndarray) -> None:
        kept, entering = old & new, new & ~old
        if np.any(entering):
            self._a = reentry_bias(self._a, kept, entering) if np.any(kept) else np.zeros_like(self._a)
        self._g = log_normalize(self._a[:, 0], new)

    def _update(self, record: BankRecord, active: np.ndarray) -> WeightsUpdate:
        loglik = gaussian_log_likelihood(record)
        phi = self._phi(record)
        log_g = log_normalize(self._a @ phi, active)
        log_h = log_normalize(np.where(active, loglik, 0.0) + log_g, active)
        self._a += self.params.eta * np.outer(np.exp(log_h) - np.exp(log_g), phi)
        self._g = log_normalize(self._a @ phi, active)
        update = self._make_update(record, self._count, self._weights(), statistic=np.exp(log_h))
        self._count += 1
        return update

    def _state_extra(self) -> dict[str, Any]:
        return {"measurements": self._count, "cell_weights": self._a.tolist()}

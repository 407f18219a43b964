"""The chi-square "optimal" gating network of Lubey & Ely 2022 (§3, eqs. 5–8).

Weights are recomputed once per batch of M measurements (the same batches for every filter, even
when a batch holds no measurement a filter processes). With G_k = diag(G_k,1 … G_k,N) the batch
chi-square sums (eq. 6)

    G_k,i = Σ_{j in batch k} G_k,i,j,   G_k,i,j = z̄_ijᵀ S_ij⁻¹ z̄_ij,

the new weights minimise (eq. 6)

    J(p, λ) = ½ pᵀ G_k p + ½ (p − p_{k−1})ᵀ W̄⁻¹ (p − p_{k−1}) + λ (1ᵀp − 1),

whose stationary point is the closed form of eq. 8:

    p_k = (G_k + W̄⁻¹)⁻¹ [W̄⁻¹ p_{k−1} − λ 1],
    λ   = (1ᵀ (G_k + W̄⁻¹)⁻¹ W̄⁻¹ p_{k−1} − 1) / (1ᵀ (G_k + W̄⁻¹)⁻¹ 1).

Details from Lubey & Ely 2022 §3.2: a-priori weights p_0 = 1/N; memory W̄ = σ_W² I with σ_W = 0.05 (any
symmetric positive definite W̄ is accepted; ``prior`` sets another p_0); a filter that does not process measurement j is
scored as nominal, G_k,i,j = n_j (the mean of a χ²_{n_j} variable), so biased data a filter never
uses cannot penalise it; ``reset`` returns to p_0.

Negative weights. The equality constraint alone does not keep p ≥ 0. Lubey & Ely 2022 argues the cost
discourages negative weights, and with W̄ = σ_W² I and p_{k−1} ≥ 0 that is usually so, but eq. 8
does go negative when a filter with a small prior weight is surrounded by much worse ones, or for
a non-diagonal W̄. A negative weight is meaningless as a probability and breaks the anomaly
trigger's "weight left its band" test, so by default (``negative_weights = "qp"``) the network
solves the same cost with the bound p ≥ 0 added — a strictly convex QP over the probability
simplex, solved exactly by a primal active-set method whose sub-problems are eq. 8 restricted to
the free filters (:func:`constrained_weights`). Whenever eq. 8 is already non-negative the two
coincide. ``negative_weights = "clip"`` instead sets negative entries of eq. 8 to zero and
renormalises (cheaper, not optimal).

Disabled filters are removed from the problem (their weights are fixed at zero), which leaves the
principal sub-matrix of W̄⁻¹ over the active filters as the memory term.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np

from fsw.filters.record import BankRecord
from fsw.gating.base import GatingNetwork, InvalidParameterError, WeightsUpdate, reenter_probabilities
from fsw.interface.typed import spec
from fsw.kernels import on_first_call

chi2_batch_sums = on_first_call(globals(), "chi2_batch_sums", "fsw.kernels.chi2_batch")

if TYPE_CHECKING:  # the two-sided network derives from this one
    from fsw.gating.chi2_two_sided import Chi2TwoSidedParams


@dataclass(frozen=True)
class Chi2Params:
    """Parameters of the Lubey & Ely 2022 chi-square gating network."""

    batch_size: int = spec(1000, doc="M: measurements per weight update (Lubey & Ely 2022 §3.2 uses 1000)", ge=1)
    sigma_w: float = spec(0.05, doc="σ_W of the memory matrix W̄ = σ_W² I (Lubey & Ely 2022 §3.2)", gt=0.0)
    memory_matrix: tuple[tuple[float, ...], ...] = spec(
        (), doc="full N×N symmetric positive definite W̄; overrides sigma_w when given"
    )
    substitute_unprocessed: bool = spec(
        True, doc="score measurements a filter does not process as G = n_j (Lubey & Ely 2022 §3.2)"
    )
    negative_weights: Literal["qp", "clip"] = spec(
        "qp", doc="how a negative eq. 8 weight is handled: exact QP with p >= 0, or clip and renormalise"
    )
    prior: tuple[float, ...] = spec(
        (), doc="a-priori weights p_0 (bank order, summing to 1); empty: 1/N (Lubey & Ely 2022 §3.2)", ge=0.0
    )
    final_batch_min: float = spec(
        0.0, doc="at the end of the arc, close a partial batch only if it holds at least this fraction of M "
        "(a shorter tail's weights are mostly the previous batch's, a duplicate detection vote)", ge=0.0, le=1.0
    )


def _memory_inverse(W: np.ndarray) -> np.ndarray:
    W = np.asarray(W, dtype=float)
    if W.ndim != 2 or W.shape[0] != W.shape[1]:
        raise InvalidParameterError(f"W̄ must be square, got shape {W.shape}")
    if not np.all(np.isfinite(W)) or not np.allclose(W, W.T, rtol=1e-10, atol=1e-14 * np.abs(W).max()):
        raise InvalidParameterError("W̄ must be finite and symmetric")
    try:
        L = np.linalg.cholesky(W)
    except np.linalg.LinAlgError:
        raise InvalidParameterError("W̄ must be positive definite") from None
    Linv = np.linalg.inv(L)
    Winv = Linv.T @ Linv
    return 0.5 * (Winv + Winv.T)


def _hessian(G: np.ndarray, Winv: np.ndarray) -> np.ndarray:
    G = np.asarray(G, dtype=float)
    return (np.diag(G) if G.ndim == 1 else G) + Winv


def _eqp(H: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """min ½xᵀHx − bᵀx subject to 1ᵀx = 1: the eq. 8 solution for Hessian H and b = W̄⁻¹p_{k−1}."""
    ones = np.ones(len(b))
    Hb = np.linalg.solve(H, np.column_stack((b, ones)))
    lam = (ones @ Hb[:, 0] - 1.0) / (ones @ Hb[:, 1])
    return Hb[:, 0] - lam * Hb[:, 1], float(lam)


def closed_form_weights(G: np.ndarray, W: np.ndarray, p_prev: np.ndarray) -> tuple[np.ndarray, float]:
    """Lubey & Ely 2022 eq. 8: weights p_k and Lagrange multiplier λ, without a sign constraint.

    ``G`` is the (N,) diagonal of G_k (or an (N, N) matrix), ``W`` the memory matrix W̄, ``p_prev``
    the previous weights p_{k−1}.
    """
    Winv = _memory_inverse(W)
    return _eqp(_hessian(G, Winv), Winv @ np.asarray(p_prev, dtype=float))


def _simplex_start(p_prev: np.ndarray) -> np.ndarray:
    x = np.clip(np.asarray(p_prev, dtype=float), 0.0, None)
    total = x.sum()
    return x / total if total > 0.0 else np.full(len(x), 1.0 / len(x))


def constrained_weights_inv(G: np.ndarray, Winv: np.ndarray, p_prev: np.ndarray, tol: float = 1e-12) -> tuple[np.ndarray, float]:
    """As :func:`constrained_weights`, given W̄⁻¹ directly."""
    H = _hessian(G, Winv)
    b = Winv @ np.asarray(p_prev, dtype=float)
    n = len(b)
    x = _simplex_start(p_prev)
    fixed = x <= 0.0
    lam = 0.0
    scale = max(1.0, float(np.abs(np.diag(H)).max()))
    for _ in range(20 * n + 20):
        free = ~fixed
        xs, lam = _eqp(H[np.ix_(free, free)], b[free])
        target = np.zeros(n)
        target[free] = xs
        d = target - x
        if np.max(np.abs(d)) <= tol:
            if not np.any(fixed):
                return target, lam
            mu = (H @ target - b + lam)[fixed]
            if mu.min() >= -tol * scale:
                return target, lam
            # Releasing the bound with the most negative multiplier lowers the cost.
            x = target
            fixed[np.flatnonzero(fixed)[int(np.argmin(mu))]] = False
            continue
        alpha, block = 1.0, -1
        for i in np.flatnonzero(free & (d < 0.0)):
            ratio = -x[i] / d[i]
            if ratio < alpha:
                alpha, block = ratio, int(i)
        x = x + alpha * d
        if block >= 0:
            x[block] = 0.0
            fixed[block] = True
    # Not reached for a strictly convex QP; x is feasible and no worse than the start.
    x = np.clip(x, 0.0, None)
    return x / x.sum(), lam


def constrained_weights(G: np.ndarray, W: np.ndarray, p_prev: np.ndarray, tol: float = 1e-12) -> tuple[np.ndarray, float]:
    """The Lubey & Ely 2022 eq. 6 cost minimised over the probability simplex (1ᵀp = 1, p ≥ 0).

    Primal active-set method: each sub-problem is eq. 8 over the filters not held at zero;
    returns (p, λ). Equals :func:`closed_form_weights` whenever that is non-negative.
    """
    return constrained_weights_inv(G, _memory_inverse(W), p_prev, tol)


def clipped_weights_inv(G: np.ndarray, Winv: np.ndarray, p_prev: np.ndarray) -> tuple[np.ndarray, float]:
    """Eq. 8, then negative weights set to zero and the rest renormalised."""
    p, lam = _eqp(_hessian(G, Winv), Winv @ np.asarray(p_prev, dtype=float))
    p = np.clip(p, 0.0, None)
    total = p.sum()
    return (p / total if total > 0.0 else np.full(len(p), 1.0 / len(p))), lam


def measurement_terms(record: BankRecord, substitute_unprocessed: bool = True) -> np.ndarray:
    """G_k,i,j of Lubey & Ely 2022 eq. 6 for one measurement j, with the §3.2 rule G = n_j for the
    filters that do not process it (when ``substitute_unprocessed``)."""
    chi2 = np.asarray(record.chi2, dtype=float)
    if not substitute_unprocessed:
        return chi2.copy()
    return np.where(np.asarray(record.processed, dtype=bool), chi2, float(record.n))


class Chi2Network(GatingNetwork):
    """Lubey & Ely 2022 chi-square gating network (eqs. 5–8) with batch length M and memory W̄."""

    # slotted: see fsw.executive.FrameExecutive
    __slots__ = ("_Winv", "_p", "_batch", "_count", "_sums", "_last_t", "_last_seq")

    name = "chi2"
    params_type: ClassVar[type] = Chi2Params

    def _check_params(self, params: Chi2Params | Chi2TwoSidedParams) -> None:
        W = self._memory_of(params)
        if W.shape != (len(self.filters), len(self.filters)):
            raise InvalidParameterError(
                f"memory_matrix must be {len(self.filters)}×{len(self.filters)}, got {W.shape}"
            )
        # also σ_W² I: a σ_W so small that its square underflows gives a singular W̄
        _memory_inverse(W)
        if params.prior:
            prior = np.asarray(params.prior, dtype=float)
            if prior.shape != (len(self.filters),) or abs(prior.sum() - 1.0) > 1e-9:
                raise InvalidParameterError(f"prior needs {len(self.filters)} weights summing to 1")

    def _memory(self) -> np.ndarray:
        return self._memory_of(self.params)

    def _memory_of(self, params: Chi2Params | Chi2TwoSidedParams) -> np.ndarray:
        if params.memory_matrix:
            return np.asarray(params.memory_matrix, dtype=float)
        return params.sigma_w**2 * np.eye(len(self.filters))

    def _params_changed(self, old: Chi2Params | Chi2TwoSidedParams, new: Chi2Params | Chi2TwoSidedParams) -> None:
        self._Winv = _memory_inverse(self._memory())

    def _reset(self) -> None:
        self._Winv = _memory_inverse(self._memory())
        n_f = len(self.filters)
        prior = np.asarray(self.params.prior, dtype=float) if self.params.prior else np.full(n_f, 1.0 / n_f)
        prior = np.where(self._active, prior, 0.0)
        total = prior.sum()
        self._p = prior / total if total > 0.0 else np.where(self._active, 1.0 / max(int(np.count_nonzero(self._active)), 1), 0.0)
        self._batch = 0
        self._clear_batch()
        self._last_t = float("nan")
        self._last_seq = -1

    def _clear_batch(self) -> None:
        self._count = 0
        # rows: chi2 processed, dim processed, chi2 / dim unprocessed (fsw.kernels.chi2_batch)
        self._sums = np.zeros((4, len(self.filters)))

    @property
    def _chi2_proc(self) -> np.ndarray:
        return np.array(self._sums[0])

    @property
    def _dim_proc(self) -> np.ndarray:
        return np.array(self._sums[1])

    @property
    def _chi2_unproc(self) -> np.ndarray:
        return np.array(self._sums[2])

    @property
    def _dim_unproc(self) -> np.ndarray:
        return np.array(self._sums[3])

    def _weights(self) -> np.ndarray:
        return self._p

    def _activation_changed(self, old: np.ndarray, new: np.ndarray) -> None:
        self._p = reenter_probabilities(self._p, old, new)

    def _update(self, record: BankRecord, active: np.ndarray) -> WeightsUpdate | None:
        n = float(record.n)
        try:
            chi2_batch_sums(record.chi2, record.processed, n, self._sums)
        except TypeError:  # not the bank's C-ordered float64 and bool arrays: converted to them
            chi2_batch_sums(np.array(record.chi2, dtype=np.float64, order="C"),
                            np.array(record.processed, dtype=np.bool_, order="C"), n, self._sums)
        self._count += 1
        self._last_t, self._last_seq = float(record.t), int(record.seq)
        if self._count >= self.params.batch_size:
            return self._complete_batch()
        return None

    def flush(self) -> WeightsUpdate | None:
        """Close the current partial batch now (e.g. at the end of a data arc, Lubey & Ely 2022 §3.2:
        "batches can be split up by other means"); None if it is empty or holds fewer than
        ``final_batch_min`` M measurements.

        Why a short tail stays open: eq. 8 blends the previous weights and the batch's evidence in
        the ratio W̄⁻¹ : G_k, and G_k grows with the batch. With σ_W = 0.05 (W̄⁻¹ = 400) a full batch
        (G ≈ 1100) keeps 27 % of the previous weights, the ~170-measurement tail that ends the
        InSight arc 70 %: its weights repeat the last full batch's excursion, and the detector's
        k-of-n rule counted that repeat as a second, independent exceedance — over nominal seeds
        the closing tail exceeded the threshold 2-3 times as often as a mid-arc batch, which
        piled false alarms up at entry (docs/validation.md, "False alarms near entry")."""
        if self._count == 0 or self._count < self.params.final_batch_min * self.params.batch_size:
            return None
        return self._complete_batch()

    def batch_statistic(self) -> np.ndarray:
        """G_k,i of the batch accumulated so far (Lubey & Ely 2022 eq. 6 with the §3.2 substitution)."""
        if self.params.substitute_unprocessed:
            return self._chi2_proc + self._dim_unproc
        return self._chi2_proc + self._chi2_unproc

    def _batch_cost(self) -> np.ndarray:
        """The diagonal placed in G_k of eq. 6 (the two-sided network overrides this)."""
        return self.batch_statistic()

    def _complete_batch(self) -> WeightsUpdate:
        cost = self._batch_cost()
        statistic = self.batch_statistic()
        act = self._active
        Winv_a = self._Winv[np.ix_(act, act)]
        solve = constrained_weights_inv if self.params.negative_weights == "qp" else clipped_weights_inv
        p_act, _ = solve(cost[act], Winv_a, self._p[act])
        p = np.zeros(len(self.filters))
        p[act] = p_act
        self._p = p
        update = WeightsUpdate(
            network=self.name, t=self._last_t, seq=self._last_seq, batch=self._batch,
            filters=self.filters, weights=p.copy(), statistic=statistic,
        )
        self._batch += 1
        self._clear_batch()
        return update

    def _state_extra(self) -> dict[str, Any]:
        return {
            "batch": self._batch,
            "pending": self._count,
            "batch_statistic": [float(g) for g in self.batch_statistic()],
        }

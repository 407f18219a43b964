"""Two-sided chi-square gating network: Lubey & Ely's (2022) network without its preference for filters
whose uncertainty is over-inflated (Lubey & Ely 2022 §3.2, "Preference for Over-Inflated Uncertainty
Metrics", left there as future work).

Derivation
----------
Lubey & Ely 2022 scores filter i over batch k by G_k,i = Σ_j z̄ᵀS⁻¹z̄ and gives weight to the filters with
the smallest G. A filter whose S is too large (inflated R or P) has a *small* G and is preferred,
although it is as wrong as one whose S is too small.

Model the consistency question per filter as a scale error of its innovation covariance: the
residuals are z̄_j ~ N(0, c S_j) for an unknown c > 0, c = 1 meaning the filter is consistent.
Over the ν = Σ_j n_j residual components the filter processed in the batch,
G = Σ_j z̄_jᵀS_j⁻¹z̄_j ~ c χ²_ν, so the log-likelihood of c is

    ℓ(c) = −½ (G / c + ν ln c) + const,

maximised at ĉ = G/ν. The generalised likelihood-ratio statistic for c = 1 is

    d(G; ν) = 2 [ℓ(ĉ) − ℓ(1)] = G − ν − ν ln(G/ν)  ≥ 0,

(the unit deviance of the Gamma family): zero exactly when G = ν, growing like G when G ≫ ν and
like −ν ln(G/ν) when G ≪ ν — it penalises residuals that are too small as well as too large, and
asymptotically d ~ χ²₁ for a consistent filter whatever ν is.

To reuse the Lubey & Ely 2022 machinery unchanged (eq. 6 cost, eq. 8 closed form / simplex QP, memory W̄,
batches, reset), the two-sided network replaces the diagonal G_k,i of eq. 6 by

    D_k,i = ν_u + max(G, ν + d(G; ν)),

where G, ν are the processed part of the batch and ν_u = Σ n_j over the measurements the filter
does not process (they keep the §3.2 value G = n_j, so biased data a filter does not use still
cannot penalise it). Properties:

* G ≥ ν (residuals too large): ν + d = G − ν ln(G/ν) ≤ G, so D = ν_u + G — exactly Lubey & Ely's (2022)
  G_k,i; everything the original network detects it still detects, with the same weights.
* G < ν (residuals too small): D = ν_u + ν + d > ν_u + ν, a penalty that grows without bound as
  the filter's S becomes more inflated (G/ν → 0).
* Consistent filter: G ≈ ν ± √(2ν) and D ≈ ν_u + ν + O(1) on the low side, so a bank of
  consistent filters keeps weights ≈ 1/N, as with Lubey & Ely 2022.
* The statistic depends on G only through G/ν and ν, so it is the same for any batch length.

A filter that processed nothing in the batch (ν = 0) scores D = ν_u, i.e. nominal.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from fsw.gating.chi2 import Chi2Network
from fsw.interface.typed import spec


def scale_deviance(G: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """d(G; ν) = G − ν − ν ln(G/ν): the likelihood-ratio statistic of "innovation covariance
    scale = 1" for G ~ c χ²_ν (zero where ν = 0)."""
    G = np.asarray(G, dtype=float)
    nu = np.asarray(nu, dtype=float)
    has = nu > 0.0
    # A zero chi-square (exactly zero residuals) is infinitely suspicious; keep it finite.
    ratio = np.maximum(np.where(has, G, 1.0) / np.where(has, nu, 1.0), 1e-300)
    return np.where(has, nu * (ratio - 1.0 - np.log(ratio)), 0.0)


def two_sided_cost(G: np.ndarray, nu: np.ndarray, nu_unprocessed: np.ndarray) -> np.ndarray:
    """D = ν_u + max(G, ν + d(G; ν)) — the G_k,i replacement derived in the module docstring."""
    G = np.asarray(G, dtype=float)
    nu = np.asarray(nu, dtype=float)
    return np.asarray(nu_unprocessed, dtype=float) + np.maximum(G, nu + scale_deviance(G, nu))


@dataclass(frozen=True)
class Chi2TwoSidedParams:
    """Parameters of the two-sided chi-square network (same meaning as the Lubey & Ely 2022 network's)."""

    batch_size: int = spec(1000, doc="M: measurements per weight update", ge=1)
    sigma_w: float = spec(0.05, doc="σ_W of the memory matrix W̄ = σ_W² I", gt=0.0)
    memory_matrix: tuple[tuple[float, ...], ...] = spec(
        (), doc="full N×N symmetric positive definite W̄; overrides sigma_w when given"
    )
    substitute_unprocessed: bool = spec(
        True, doc="score measurements a filter does not process as nominal (Lubey & Ely 2022 §3.2)"
    )
    negative_weights: Literal["qp", "clip"] = spec(
        "qp", doc="how a negative eq. 8 weight is handled: exact QP with p >= 0, or clip and renormalise"
    )
    prior: tuple[float, ...] = spec(
        (), doc="a-priori weights p_0 (bank order, summing to 1); empty: 1/N (Lubey & Ely 2022 §3.2)", ge=0.0
    )
    final_batch_min: float = spec(
        0.0, doc="at the end of the arc, close a partial batch only if it holds at least this fraction of M", ge=0.0, le=1.0
    )


class Chi2TwoSidedNetwork(Chi2Network):
    """Lubey & Ely 2022 network with G_k,i replaced by the two-sided cost D_k,i (see module docstring)."""

    __slots__ = ()  # slotted: see fsw.executive.FrameExecutive

    name = "chi2-two-sided"
    params_type = Chi2TwoSidedParams

    def _batch_cost(self) -> np.ndarray:
        if self.params.substitute_unprocessed:
            return two_sided_cost(self._chi2_proc, self._dim_proc, self._dim_unproc)
        return two_sided_cost(
            self._chi2_proc + self._chi2_unproc, self._dim_proc + self._dim_unproc, np.zeros(len(self.filters))
        )

"""Hierarchical mixture-of-experts gating (Chaer et al. 1998 §III, eqs. 2–16).

The filters are split into K banks (groups). A gate inside bank i weighs its filters, a top-level
gate weighs the banks; both are softmax cells trained online by gradient ascent:

    g_i     = softmax_i(a_iᵀ φ)                    top level, eqs. 2–3
    g_{j|i} = softmax_j(a_{j|i}ᵀ φ) within bank i  eqs. 4–5
    f(z) = Σ_i g_i Σ_j f(z | α_{j|i}) g_{j|i}     eq. 6 (Gaussian f, eq. 7)
    h_i     = g_i Σ_j f_{j|i} g_{j|i} / f(z)        eq. 9
    h_{j|i} = f_{j|i} g_{j|i} / Σ_j f_{j|i} g_{j|i} eq. 10
    a_i     ← a_i + η_top (h_i − g_i) φ                 eq. 15
    a_{j|i} ← a_{j|i} + η_i h_i (h_{j|i} − g_{j|i}) φ   eq. 16

The overall weight of filter j in bank i is g_i · g_{j|i}; updates report both levels. All
probabilities are computed with log-densities and log-sum-exp. The learning rate may differ per
level and per bank (Chaer et al. 1998: "This parameter need not be the same for all gating networks").
Features φ are those of :mod:`fsw.gating.moe` (constant 1 by default, for the reasons given there).
The gates start equal (zero cell weights), Chaer et al. 1998 §III's "same small values".

A bank whose filters are all disabled gets top-level weight zero; filters re-entering a bank (and
banks re-entering the top level) get the a-priori share of their level, as in the one-level network.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from fsw.filters.record import BankRecord
from fsw.gating.base import GatingNetwork, InvalidParameterError, WeightsUpdate, log_normalize
from fsw.gating.magill import gaussian_log_likelihood
from fsw.gating.moe import feature_vector, reentry_bias
from fsw.interface.typed import spec


@dataclass(frozen=True)
class HierarchicalParams:
    """Parameters of the two-level (bank / filter) gating network."""

    groups: dict[str, tuple[str, ...]] = spec(
        default_factory=dict,
        doc="bank name -> filter names; every filter in exactly one bank; empty: one bank with all filters",
    )
    eta_top: float = spec(1.0, doc="learning rate of the top-level gate (Chaer et al. 1998 eq. 15)", gt=0.0)
    eta_bank: float = spec(1.0, doc="learning rate of the in-bank gates (Chaer et al. 1998 eq. 16)", gt=0.0)
    eta_banks: dict[str, float] = spec(default_factory=dict, doc="per-bank learning rates overriding eta_bank")
    features: Literal["constant", "kind"] = spec("constant", doc="input features φ (see the moe network)")
    kinds: tuple[str, ...] = spec((), doc="measurement kinds of the one-hot features (features = 'kind')")


def _logsumexp_groups(values: np.ndarray, group: np.ndarray, n_groups: int) -> np.ndarray:
    out = np.full(n_groups, -np.inf)
    for gi in range(n_groups):
        v = values[group == gi]
        if v.size and np.any(np.isfinite(v)):
            top = np.max(v)
            out[gi] = top + np.log(np.sum(np.exp(v - top)))
    return out


class HierarchicalNetwork(GatingNetwork):
    """Chaer et al. 1998 two-level gating network (per-measurement network)."""

    name = "hierarchical"
    params_type = HierarchicalParams

    def _check_params(self, params: HierarchicalParams) -> None:
        groups = params.groups or {"bank": self.filters}
        seen: dict[str, str] = {}
        for gname, members in groups.items():
            if not members:
                raise InvalidParameterError(f"bank {gname!r} has no filters")
            for m in members:
                if m not in self.filters:
                    raise InvalidParameterError(f"bank {gname!r}: unknown filter {m!r}")
                if m in seen:
                    raise InvalidParameterError(f"filter {m!r} is in banks {seen[m]!r} and {gname!r}")
                seen[m] = gname
        missing = [f for f in self.filters if f not in seen]
        if missing:
            raise InvalidParameterError(f"filters in no bank: {missing}")
        unknown = set(params.eta_banks) - set(groups)
        if unknown:
            raise InvalidParameterError(f"eta_banks names unknown banks: {sorted(unknown)}")
        for gname, eta in params.eta_banks.items():
            if not eta > 0.0:
                raise InvalidParameterError(f"eta_banks[{gname!r}] must be > 0")

    def _layout(self) -> None:
        groups = self.params.groups or {"bank": self.filters}
        self.group_names: tuple[str, ...] = tuple(groups)
        member = {m: gi for gi, members in enumerate(groups.values()) for m in members}
        self._group = np.array([member[f] for f in self.filters], dtype=int)
        self._eta_bank = np.array(
            [self.params.eta_banks.get(g, self.params.eta_bank) for g in self.group_names], dtype=float
        )

    def _dim(self) -> int:
        return 1 if self.params.features == "constant" else 1 + len(self.params.kinds)

    def _reset(self) -> None:
        self._layout()
        d = self._dim()
        self._a_top = np.zeros((len(self.group_names), d))
        self._a_in = np.zeros((len(self.filters), d))
        self._phi = np.zeros(d)
        self._phi[0] = 1.0
        self._count = 0

    def _params_changed(self, old: HierarchicalParams, new: HierarchicalParams) -> None:
        if (old.groups, old.features, old.kinds) != (new.groups, new.features, new.kinds):
            self._reset()
        else:
            self._layout()

    def _bank_active(self, active: np.ndarray) -> np.ndarray:
        return np.array([np.any(active[self._group == gi]) for gi in range(len(self.group_names))])

    def _gates(self, phi: np.ndarray, active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """log g_i (K,) and log g_{j|i} (N,) for input φ."""
        log_top = log_normalize(self._a_top @ phi, self._bank_active(active))
        u_in = self._a_in @ phi
        log_cond = np.full(len(self.filters), -np.inf)
        for gi in range(len(self.group_names)):
            members = (self._group == gi) & active
            if np.any(members):
                log_cond[members] = log_normalize(u_in, members)[members]
        return log_top, log_cond

    def _weights(self) -> np.ndarray:
        log_top, log_cond = self._gates(self._phi, self._active)
        return np.exp(log_top[self._group] + log_cond)

    def level_weights(self) -> tuple[np.ndarray, np.ndarray]:
        """(g_i per bank (K,), g_{j|i} per filter (N,)) at the last input."""
        log_top, log_cond = self._gates(self._phi, self._active)
        return np.exp(log_top), np.exp(log_cond)

    def _activation_changed(self, old: np.ndarray, new: np.ndarray) -> None:
        for gi in range(len(self.group_names)):
            members = self._group == gi
            kept, entering = members & old & new, members & new & ~old
            if not np.any(entering):
                continue
            if np.any(kept):
                self._a_in = reentry_bias(self._a_in, kept, entering)
            else:
                self._a_in[members] = 0.0
        old_banks, new_banks = self._bank_active(old), self._bank_active(new)
        kept_b, entering_b = old_banks & new_banks, new_banks & ~old_banks
        if np.any(entering_b):
            self._a_top = reentry_bias(self._a_top, kept_b, entering_b) if np.any(kept_b) else np.zeros_like(self._a_top)

    def _update(self, record: BankRecord, active: np.ndarray) -> WeightsUpdate:
        loglik = np.where(active, gaussian_log_likelihood(record), 0.0)
        phi = feature_vector(record, self.params.features, self.params.kinds)
        n_groups = len(self.group_names)
        log_top, log_cond = self._gates(phi, active)
        # log Σ_j f_{j|i} g_{j|i}: each bank's mixture density of z (inner sum of eq. 6).
        log_bank = _logsumexp_groups(loglik + log_cond, self._group, n_groups)
        bank_active = self._bank_active(active)
        log_h_top = log_normalize(np.where(bank_active, log_top + log_bank, -np.inf), bank_active)
        log_h_cond = np.full(len(self.filters), -np.inf)
        log_h_cond[active] = loglik[active] + log_cond[active] - log_bank[self._group[active]]
        h_top, g_top = np.exp(log_h_top), np.exp(log_top)
        h_cond, g_cond = np.exp(log_h_cond), np.exp(log_cond)
        self._a_top += self.params.eta_top * np.outer(h_top - g_top, phi)
        step = self._eta_bank[self._group] * h_top[self._group] * (h_cond - g_cond)
        self._a_in += np.outer(step, phi)
        self._phi = phi
        top, cond = self.level_weights()
        update = self._make_update(
            record, self._count, top[self._group] * cond,
            group_names=self.group_names, group_weights=top, conditional_weights=cond,
        )
        self._count += 1
        return update

    def _state_extra(self) -> dict[str, Any]:
        top, cond = self.level_weights()
        return {
            "measurements": self._count,
            "groups": {g: float(w) for g, w in zip(self.group_names, top)},
            "conditional_weights": [float(w) for w in cond],
        }

"""EM on a recorded run split at its switch (Chaer et al. 1998 §V): the measurements before and after
the switch the online gate shows are treated as two statistically coherent sets, and EM with IRLS
(``ground.tuning.em_irls``) finds each set's maximum-likelihood gate parameters. With the FSW's
input φ = [1] each set's EM weights are constants: the set's mixing proportions of banks and of
filters within banks."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ground.tuning import em_irls as em
from ground.tuning.recorded_residuals import HierarchyData


@dataclass
class SegmentFit:
    start: int  # first measurement index (inclusive)
    stop: int  # last (exclusive)
    result: em.EmResult
    top: np.ndarray  # (K,) g_i
    in_bank: list[np.ndarray]  # per bank (L_i,) g_{j|i}

    def as_dict(self, data: HierarchyData) -> dict:
        r = self.result
        return {"start": self.start, "stop": self.stop, "t_start_s": float(data.t_s[self.start]),
                "t_stop_s": float(data.t_s[self.stop - 1]), "iterations": r.iterations, "converged": r.converged,
                "log_likelihood": [round(x, 6) for x in r.log_likelihood],
                "top": dict(zip(data.banks, np.round(self.top, 6).tolist())),
                "in_bank": {b: dict(zip(data.bank_filters[b], np.round(w, 6).tolist()))
                            for b, w in zip(data.banks, self.in_bank)}}


def fit_segments(data: HierarchyData, split: int | None, *, epsilon: float = 1e-4,
                 max_iterations: int = 5000) -> list[SegmentFit]:
    """EM per segment ([0, split) and [split, N), or the whole set if ``split`` is None), stopping
    when the L1 change of the gate weights is below ε (weights going to zero send their
    parameters to infinity, see :func:`ground.tuning.em_irls.run_em`)."""
    N = len(data.t_s)
    cuts = [0, N] if split is None else [0, int(split), N]
    if any(b - a < 1 for a, b in zip(cuts, cuts[1:])):
        raise ValueError(f"split {split} leaves an empty segment of {N} measurements")
    out = []
    for a, b in zip(cuts, cuts[1:]):
        res = em.run_em([lf[a:b] for lf in data.log_f], epsilon=epsilon, max_iterations=max_iterations,
                         change_of="weights")
        top, in_bank = em.weights(res.theta, np.ones((1, 1)))
        out.append(SegmentFit(a, b, res, top[0], [w[0] for w in in_bank]))
    return out

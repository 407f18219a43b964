"""Fused-filter consistency over nominal seeds: NEES against truth and NIS per measurement kind.

Flies ``tools.bench.consistency.fly`` for each seed (nominal scenario, no fault) and reports, for
one filter (default ``fused``):

* the average NEES over runs and epochs for position (3 dof), velocity (3) and both (6), and the
  fraction of epochs whose run-average NEES lies below / above the two-sided 95 % band of an
  average of R chi-square variables (Bar-Shalom, Li & Kirubarajan 2001 §5.4);
* the NIS per measurement kind: the sum of z̄ᵀS⁻¹z̄ over the processed measurements divided by
  the summed dimensions (1 when consistent), with its 95 % band.

Run: ``navbank consistency --seeds 20 --out FILE.json``.
"""

from __future__ import annotations

import numpy as np

from tools.bench.consistency import Flight, average_band, monte_carlo, sum_band


def summarize(flights: list[Flight], name: str = "fused", skip_epochs: int = 1) -> dict:
    """The consistency figures of filter ``name`` (the first ``skip_epochs`` epochs, the a-priori
    itself, are left out: its NEES is the a-priori draw, not the filter)."""
    i = flights[0].index(name)
    k = min(f.t.size for f in flights)
    runs = len(flights)
    out: dict = {"filter": name, "runs": runs, "epochs": k - skip_epochs, "nees": {}, "nis": {}}
    for label, dims, dof in (("position", slice(0, 3), 3), ("velocity", slice(3, 6), 3), ("6-dof", slice(0, 6), 6)):
        per_run = np.stack([f.nees(dims)[i, skip_epochs:k] for f in flights])  # (R, K)
        avg = per_run.mean(axis=0)
        lo, hi = average_band(dof, runs)
        out["nees"][label] = {"dof": dof, "mean": float(avg.mean()), "band": [lo, hi],
                              "below": float(np.mean(avg < lo)), "above": float(np.mean(avg > hi))}
    kinds = sorted({str(kd) for f in flights for kd in f.meas_kind})
    for kind in kinds:
        s = d = 0.0
        for f in flights:
            sel = (f.meas_kind == kind) & f.processed[i]
            s += float(f.chi2[i, sel].sum())
            d += float(f.meas_dim[sel].sum())
        if d:
            lo, hi = sum_band(d)
            out["nis"][kind] = {"mean": s / d, "dims": d, "band": [lo, hi]}
    return out


def measure(seeds: int, first_seed: int = 1001, workers: int = 2, scenario: str = "insight-approach",
            name: str = "fused") -> dict:
    """Fly ``seeds`` nominal runs from ``first_seed`` and summarise filter ``name``."""
    flights = monte_carlo(range(first_seed, first_seed + seeds), workers=workers, scenario=scenario)
    return summarize(flights, name)

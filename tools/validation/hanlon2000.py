"""Hanlon & Maybeck 2000 on navbank's linear actuator-failure case (``sim.scenarios.actuator_dither``):
identification time of a failed actuator against the dither amplitude, for the magnitude-based bank
(``magill``, the MMAE rule on residual magnitudes) and the residual-correlation bank
(``residual-correlation``, the periodogram statistic at the dither frequencies, eqs. 18–22), both
over navbank's linear filter bank with the same lower bound on the probabilities (1e-3).

Identification: the first sample after the failure from which the failed actuator's hypothesis
keeps a weight above 0.9 for ``HOLD`` samples. False declaration: before the failure, a failure
hypothesis above 0.9.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fsw.filters.linear import LinearFilterBank
from fsw.gating import make_network
from sim.scenarios import actuator_dither as ad

MULTIPLIERS = (1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01)
NETWORKS = {"magill": {"lower_bound": 1e-3},
            "residual-correlation": {"window": 100, "frequencies": ad.FREQUENCIES, "lower_bound": 1e-3}}
HOLD = 50
FAIL_AT = 300
LENGTH = 1300


def weights(run: ad.DitherRun, amplitude: float) -> dict[str, np.ndarray]:
    """(K, 4) weights of each network on one run."""
    mats = ad.bank_matrices(amplitude)
    bank = LinearFilterBank(ad.HYPOTHESES, mats["F"], mats["Q"], mats["H"], mats["R"], mats["x0"], mats["P0"])
    nets = {name: make_network(name, ad.HYPOTHESES, p) for name, p in NETWORKS.items()}
    uniform = np.full(len(ad.HYPOTHESES), 1.0 / len(ad.HYPOTHESES))
    last = {name: uniform for name in nets}
    out: dict[str, list[np.ndarray]] = {name: [] for name in nets}
    for k, z in enumerate(run.z):
        rec = bank.update(z, t=k * ad.DT, seq=k) if k == 0 else bank.step(z, t=k * ad.DT, seq=k)
        for name, net in nets.items():
            upd = net.update(rec)
            if upd is not None:
                last[name] = np.asarray(upd.weights)
            out[name].append(last[name])
    return {name: np.array(v) for name, v in out.items()}


def identification(W: np.ndarray, failed: int, fail_at: int) -> tuple[float | None, bool]:
    """(samples from the failure to identification or None, false declaration before it)."""
    false = bool(np.any(W[:fail_at, 1:] > 0.9))
    above = W[fail_at:, failed] > 0.9
    for k in range(len(above) - HOLD + 1):
        if above[k:k + HOLD].all():
            return float(k), false
    return None, false


@dataclass
class Hanlon2000Results:
    runs: int = 0
    time_s: dict[str, dict[float, list[float | None]]] = field(default_factory=dict)  # network -> multiplier -> per run
    false: dict[str, int] = field(default_factory=dict)

    def median_s(self, network: str, mult: float) -> float | None:
        """Median identification time [s]; None when half the runs or more never identify."""
        v = self.time_s[network][mult]
        ok = sorted(x for x in v if x is not None)
        if len(ok) * 2 <= len(v):
            return None
        return float(np.median([x if x is not None else np.inf for x in v]))


def run_hanlon2000(runs: int = 6, multipliers: tuple[float, ...] = MULTIPLIERS) -> Hanlon2000Results:
    out = Hanlon2000Results(runs=runs, time_s={n: {m: [] for m in multipliers} for n in NETWORKS},
                            false={n: 0 for n in NETWORKS})
    for mult in multipliers:
        for seed in range(runs):
            failed = 1 + seed % ad.N_ACT
            run = ad.generate(np.random.default_rng(seed), ad.AMPLITUDE * mult, failed, FAIL_AT, LENGTH)
            for name, W in weights(run, ad.AMPLITUDE * mult).items():
                k, false = identification(W, failed, FAIL_AT)
                out.time_s[name][mult].append(None if k is None else k * ad.DT)
                out.false[name] += int(false)
    return out

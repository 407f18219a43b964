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
from pathlib import Path

import numpy as np

from fsw.filters.linear import LinearFilterBank
from fsw.gating import make_network
from sim.scenarios import actuator_dither as ad
from tools.validation.claims import Claim
from tools.validation.section import Section, claims_lines, figure_links, table

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


def plot_hanlon2000(r: Hanlon2000Results, path: Path) -> Path:
    """Median identification time against the dither multiplier (Figs. 7–9 analogue)."""
    from ground.report.figure import new_figure, save

    fig, ax = new_figure(1, 1, size=(7.0, 4.0))
    mults = sorted(r.time_s["magill"], reverse=True)
    for name in NETWORKS:
        y = [r.median_s(name, mlt) for mlt in mults]
        ax.plot(mults, [np.nan if v is None or not np.isfinite(v) else v for v in y], "o-", label=name)
    ax.set_xscale("log")
    ax.invert_xaxis()
    ax.set_xlabel("dither amplitude multiplier")
    ax.set_ylabel("median identification time [s]")
    ax.set_title("missing point: half the runs or more never identify the failed actuator", fontsize=8)
    ax.legend(fontsize=8)
    return save(fig, path)


def hanlon2000_section(r: Hanlon2000Results, figure: Path, doc_dir: Path) -> Section:
    s = Section("Hanlon & Maybeck 2000: residual correlation against residual magnitude, linear actuator-failure case")
    mults = sorted(r.time_s["magill"], reverse=True)
    s.lines += [
        "Hanlon & Maybeck 2000's question on navbank's linear actuator-failure case (`sim.scenarios.actuator_dither`: "
        "two-axis attitude at 100 Hz, three actuators each dithered at its own known frequency, 0.05 / 0.08 / 0.11 "
        "cycles per sample, one hypothesis per failed actuator plus the nominal one; navbank's linear bank). The "
        f"failure of one actuator comes at {FAIL_AT * ad.DT:g} s; identification is the first sample from which its "
        f"hypothesis keeps a weight above 0.9 for {HOLD} samples. `magill` (the MMAE rule on residual magnitudes) "
        "against `residual-correlation` (eqs. 18–22: the periodogram of the normalised residuals at the dither "
        "frequencies, N = 100, analytic conditional mean and covariance), both with the 1e-3 lower bound. "
        f"{r.runs} runs per multiplier (each actuator fails in turn). The paper's own aircraft model was not "
        "reproduced; this is the same experiment on navbank's own linear model.",
        "",
        "Computed by `navbank validation-report` itself (about a minute).",
        "",
    ]
    rows = []
    for mlt in mults:
        row = [f"{mlt:g}"]
        for name in NETWORKS:
            v = r.time_s[name][mlt]
            ok = [x for x in v if x is not None]
            med = r.median_s(name, mlt)
            row.append(f"{len(ok)}/{len(v)}" + (f", median {med:.2f} s" if med is not None else ""))
        rows.append(row)
    s.lines += table(["dither multiplier", "magill: identified, time", "residual-correlation: identified, time"], rows)
    total = r.runs * len(mults)
    s.lines += ["", f"False declarations (a failure hypothesis above 0.9 before the failure), runs out of {total}: "
                + ", ".join(f"{n} {r.false[n]}" for n in NETWORKS) + ".", ""]
    small = [mlt for mlt in mults if mlt <= 0.02]
    mag_small = sum(x is not None for mlt in small for x in r.time_s["magill"][mlt])
    rc_small = sum(x is not None for mlt in small for x in r.time_s["residual-correlation"][mlt])
    n_small = r.runs * len(small)
    rc1 = r.median_s("residual-correlation", max(mults))
    s.claims = [
        Claim("hm-small", "the residual-correlation bank identifies failures at dither amplitudes where the "
              "magnitude-based bank cannot", rc_small > n_small // 2 and mag_small == 0,
              f"multipliers ≤ 0.02: residual-correlation {rc_small}/{n_small} runs, magill {mag_small}/{n_small}"),
        Claim("hm-delay", "the periodogram window costs about 1 s of detection delay at full dither (paper: ~1 s, N = 100)",
              rc1 is not None and 0.2 <= rc1 <= 2.0,
              f"residual-correlation median {rc1} s, magill {r.median_s('magill', max(mults))} s at multiplier {max(mults):g}"),
        Claim("hm-false", "no false declarations in nominal operation", r.false["residual-correlation"] == 0,
              f"residual-correlation {r.false['residual-correlation']}, magill {r.false['magill']} of {total} runs"),
    ]
    s.lines += ["Findings:", "", *claims_lines(s.claims), "", *figure_links([figure], doc_dir), ""]
    return s


HANLON2000_DISCUSSION = """\
**Differences and caveats.** The paper's linear aircraft model and its Figs. 7–9 are not reproduced number for
number; the comparison is made on navbank's own linear attitude model with the paper's window (N = 100 at 100
Hz). The qualitative result holds: the magnitude-based bank loses the failure once the dither's contribution to
the residuals drowns in their noise, the periodogram statistic keeps finding it down to a 1 % dither. But the
residual-correlation bank, updating its probabilities on every sample from overlapping windows with the analytic
conditional covariance, also declares failures in nominal operation — the heavy tail of the periodogram (an
exponential variable per frequency and component) moves the probabilities faster than the lower bound lets them
recover. With that many false declarations some identifications at the smallest multipliers may be
chance (a wrong hypothesis that happens to be the failed one); the 50-sample hold makes that less likely but
does not exclude it. Hanlon & Maybeck learned the conditional statistics from 400 samples of nominal operation
(`calibration: learn`); that, a stricter identification rule, or fewer components in the statistic is the next
thing to try. The spacecraft case (a thruster or wheel failure in the EKF bank) is not built yet."""

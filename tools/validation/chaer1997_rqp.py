"""Chaer et al. 1997 §V.D (Experiment 4) on navbank's ``chaer-tracking`` scenario: RQP parameter
adaptation of the best filter (§IV, eqs. 21–23) every 200 s, starting from the Table IV bank.

Each seed flies 1000 measurements of the 2-state tracking example with α* (the paper's "actual
solution") as the truth and filters them twice with navbank's linear bank gated by ``moe`` (η = 1,
as in the paper): once with :class:`fsw.filters.rqp.LinearBankAdaptation` (window 200, SLSQP paused
after at most 20 evaluations per measurement, §V.D's restart of every filter from the best estimate with
P₀⁻) and once without. Numbers (medians over seeds): the filter chosen and the α found at the first
adaptation against the paper's, the distance of the adapted α to α* after each adaptation, J (eq. 22)
before/after, and the RMS error of the best filter's estimate before and after adaptation against the
unadapted bank on the same measurements (the analogue of Figs. 10 and 13).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fsw.filters.linear import LinearFilterBank
from fsw.filters.rqp import LinearBankAdaptation, RqpBounds, RqpOutcome
from fsw.gating import make_network
from sim.scenarios import chaer_tracking as ct
from tools.validation.section import Section, claims_lines, figure_links, table
from tools.validation.claims import Claim

NAMES = tuple(f"KF{i}" for i in range(1, 6))
#: Eq. 23's boxes for this example: Q in [1e-3, 100] (Table IV's q = 0 becomes the floor), R in [0.1, 100].
BOUNDS = RqpBounds((1e-3, 1e-3, 0.1, 0.1), (100.0, 100.0, 100.0, 100.0))
LENGTH = 1000


@dataclass
class FlightLog:
    weights: np.ndarray  # (K, 5)
    best_error: np.ndarray  # (K, 2): best filter's estimate minus truth after each measurement
    outcomes: list[RqpOutcome]
    cpu_s: float


def fly(run: ct.TrackingRun, adapt: bool) -> FlightLog:
    """Filter one Experiment 4 sequence with (or without) RQP adaptation."""
    alpha = ct.bank_parameters(4)
    Q = np.zeros((5, 2, 2))
    R = np.zeros((5, 2, 2))
    Q[:, 0, 0], Q[:, 1, 1], R[:, 0, 0], R[:, 1, 1] = alpha.T
    bank = LinearFilterBank(NAMES, ct.TRANSITION, Q, ct.MEASUREMENT_MATRIX, R, ct.FILTER_INITIAL_STATE,
                            ct.FILTER_INITIAL_COVARIANCE)
    net = make_network("moe", NAMES, {"eta": 1.0})
    rqp = LinearBankAdaptation(bank, BOUNDS, ct.EXPERIMENT_4_PERIOD, P_restart=ct.FILTER_INITIAL_COVARIANCE) \
        if adapt else None
    W, E = [], []
    cpu = 0.0
    for k, z in enumerate(run.z):
        if rqp is not None:
            rqp.before()
        rec = bank.update(z, t=run.t[k], seq=k) if k == 0 else bank.step(z, t=run.t[k], seq=k)
        upd = net.update(rec)
        assert upd is not None
        w = np.asarray(upd.weights)
        i = int(np.argmax(w))
        E.append(bank.x[i] - run.x[k])
        W.append(w)
        if rqp is not None:
            c0 = time.process_time()
            rqp.after(z, w, float(run.t[k]))
            cpu += time.process_time() - c0
    return FlightLog(np.array(W), np.array(E), [] if rqp is None else rqp.outcomes, cpu)


def alpha_distance(alpha: np.ndarray) -> float:
    """‖(α − α*) / α*‖: every component counts by its relative error (a component driven to its
    floor counts 1, not the log of the floor)."""
    truth = np.asarray(ct.EXPERIMENT_4_TRUTH)
    return float(np.linalg.norm((np.asarray(alpha) - truth) / truth))


@dataclass
class Experiment4Results:
    runs: int = 0
    first_filter: list[str] = field(default_factory=list)
    first_alpha: list[list[float]] = field(default_factory=list)  # per run
    distance: list[list[float]] = field(default_factory=list)  # per run: before, after each adaptation
    nll: list[list[tuple[float, float]]] = field(default_factory=list)
    rms_adapted: list[list[float]] = field(default_factory=list)  # per run, per 200-block: range RMS
    rms_fixed: list[list[float]] = field(default_factory=list)
    vrms_adapted: list[list[float]] = field(default_factory=list)
    vrms_fixed: list[list[float]] = field(default_factory=list)
    cpu_per_adaptation_s: list[float] = field(default_factory=list)
    iterations: list[int] = field(default_factory=list)
    example: dict[str, np.ndarray] = field(default_factory=dict)

    def median_first_alpha(self) -> np.ndarray:
        return np.median(np.array(self.first_alpha), axis=0)


def _block_rms(err: np.ndarray, col: int) -> list[float]:
    P = ct.EXPERIMENT_4_PERIOD
    return [float(np.sqrt(np.mean(err[b:b + P, col] ** 2))) for b in range(0, len(err), P)]


def run_experiment_4(runs: int = 12, length: int = LENGTH, example_seed: int = 0) -> Experiment4Results:
    out = Experiment4Results(runs=runs)
    for seed in range(runs):
        run = ct.experiment_4(np.random.default_rng(1000 + seed), length=length)
        a, f = fly(run, True), fly(run, False)
        first = a.outcomes[0]
        out.first_filter.append(first.filter)
        out.first_alpha.append(list(first.alpha_after))
        d = [alpha_distance(np.array(first.alpha_before))] + [alpha_distance(np.array(o.alpha_after))
                                                             for o in a.outcomes if o.filter == first.filter]
        out.distance.append(d)
        out.nll.append([(o.nll_before, o.nll_after) for o in a.outcomes])
        out.rms_adapted.append(_block_rms(a.best_error, 0))
        out.rms_fixed.append(_block_rms(f.best_error, 0))
        out.vrms_adapted.append(_block_rms(a.best_error, 1))
        out.vrms_fixed.append(_block_rms(f.best_error, 1))
        out.cpu_per_adaptation_s.append(a.cpu_s / max(1, len(a.outcomes)))
        out.iterations += [o.iterations for o in a.outcomes]
        if seed == example_seed:
            out.example = {"adapted": a.weights, "fixed": f.weights, "err_adapted": a.best_error,
                           "err_fixed": f.best_error}
    return out


def plot_experiment_4(results: Experiment4Results, path: Path) -> Path:
    """Gating weights with and without adaptation (Fig. 10 analogue) and the best filter's range
    error (Fig. 13 analogue), one seed."""
    from ground.report.figure import new_figure, save

    ex = results.example
    fig, axes = new_figure(3, 1, size=(10.0, 7.5), sharex=True)
    k = np.arange(1, len(ex["adapted"]) + 1)
    for ax, key, title in ((axes[0], "fixed", "weights, Table IV bank, no adaptation"),
                           (axes[1], "adapted", "weights, RQP adaptation of the best filter every 200 s")):
        for i in range(ex[key].shape[1]):
            ax.plot(k, ex[key][:, i], lw=1.1, label=NAMES[i])
        ax.set_title(title, fontsize=9)
        ax.set_ylabel("weight")
    axes[0].legend(fontsize=7, ncol=5, loc="upper right")
    axes[2].plot(k, ex["err_fixed"][:, 0], lw=0.8, color="0.6", label="no adaptation")
    axes[2].plot(k, ex["err_adapted"][:, 0], lw=0.8, color="C3", label="RQP adaptation")
    axes[2].set_ylim(-15, 15)
    axes[2].set_ylabel("best filter range error [m]")
    axes[2].set_xlabel("measurement")
    axes[2].legend(fontsize=7)
    for ax in axes:
        for c in range(ct.EXPERIMENT_4_PERIOD, len(k), ct.EXPERIMENT_4_PERIOD):
            ax.axvline(c + 0.5, color="0.5", ls="--", lw=0.8)
    return save(fig, path)


def _fmt(a: np.ndarray | tuple[float, ...] | list[float]) -> str:
    return "[" + " ".join(f"{x:.2f}" for x in a) + "]"


def experiment4_section(results: Experiment4Results, figure: Path, doc_dir: Path) -> Section:
    """The validation-report section of Chaer et al. 1997 §V.D."""
    r = results
    s = Section("Chaer et al. 1997 §V.D: RQP adaptation of the best filter on `chaer-tracking`")
    first = r.median_first_alpha()
    D = np.array(r.distance)  # (runs, 1 + adaptations)
    nll = np.array(r.nll)  # (runs, adaptations, 2)
    ra, rf = np.median(r.rms_adapted, axis=0), np.median(r.rms_fixed, axis=0)
    va, vf = np.median(r.vrms_adapted, axis=0), np.median(r.vrms_fixed, axis=0)
    kf1 = sum(f == "KF1" for f in r.first_filter)
    s.lines += [
        "Experiment 4 of Chaer et al. 1997 (§IV eqs. 21–23, §V.D): the Table IV bank, gated by `moe` (η = 1), "
        "and every 200 s the filter of largest weight re-tuned by maximising the likelihood (eq. 22) of the last "
        "200 measurements over α = [q1 q2 r1 r2] inside eq. 23's boxes (Q ∈ [10⁻³, 100], R ∈ [0.1, 100]), from "
        "its current α, with scipy's SLSQP (`fsw.filters.rqp`); then, as §V.D describes, every filter restarts "
        "from that filter's estimate with P₀⁻. The truth uses the paper's \"actual solution\" α* (the paper does "
        "not state the generating parameters). The search is paused after at most 20 likelihood evaluations per "
        f"measurement and resumed at the next (SLSQP's reverse-communication core keeps its state), so it spans "
        f"measurements instead of delaying one. Medians over {r.runs} runs of "
        f"{len(r.rms_adapted[0]) * ct.EXPERIMENT_4_PERIOD} measurements; the unadapted bank filters the same "
        "measurements.",
        "",
        "Computed by `navbank validation-report` itself (about 30 s).",
        "",
    ]
    s.lines += table(["", "q1", "q2", "r1", "r2"], [
        ["α* (truth)", *(f"{x:.2f}" for x in ct.EXPERIMENT_4_TRUTH)],
        ["KF 1 before (Table IV)", *(f"{x:.2f}" for x in ct.TABLE_IV[0])],
        ["first adaptation, paper", *(f"{x:.2f}" for x in ct.EXPERIMENT_4_PAPER_FIRST)],
        ["first adaptation, navbank (median)", *(f"{x:.2f}" for x in first)],
    ])
    s.lines += ["", f"q1 went to its floor (10⁻³) in {sum(a[0] < 0.01 for a in r.first_alpha)} of {r.runs} first "
                "adaptations: with range and velocity both measured, 200 measurements hardly tell range process "
                "noise from range measurement noise, and the likelihood is flat along q1.", ""]
    s.lines += ["After each adaptation (t = 200, 400, 600, 800 s; the result is applied when the search ends, "
                "a few measurements later):", ""]
    rows = [["before", f"{np.median(D[:, 0]):.2f}", "", "", f"{ra[0]:.2f}", f"{rf[0]:.2f}", f"{va[0]:.2f}",
             f"{vf[0]:.2f}"]]
    for j in range(1, D.shape[1]):
        rows.append([f"adaptation {j}", f"{np.median(D[:, j]):.2f}", f"{np.median(nll[:, j - 1, 0]):.1f}",
                     f"{np.median(nll[:, j - 1, 1]):.1f}",
                     f"{ra[j]:.2f}" if j < len(ra) else "", f"{rf[j]:.2f}" if j < len(rf) else "",
                     f"{va[j]:.2f}" if j < len(va) else "", f"{vf[j]:.2f}" if j < len(vf) else ""])
    s.lines += table(["", "‖(α − α*)/α*‖ of the tuned filter", "J before", "J after",
                      "range RMS [m], adapted", "no adaptation", "velocity RMS [m/s], adapted", "no adaptation"],
                     rows)
    cpu = float(np.median(r.cpu_per_adaptation_s))
    s.lines += ["", f"Cost: median {cpu * 1e3:.0f} ms CPU per adaptation (SLSQP iterations: median "
                f"{np.median(r.iterations):g}, at most {max(r.iterations)}), spread over the measurements that "
                "follow the window.", ""]
    later = slice(1, None)
    s.claims = [
        Claim("s3-rqp-best", "the gating network prefers KF 1 at the first adaptation (paper: KF 1)",
              kf1 >= 0.9 * r.runs, f"KF 1 in {kf1} of {r.runs} runs"),
        Claim("s3-rqp-toward", "the adapted parameters move toward the true ones",
              bool(np.median(D[:, 1]) < np.median(D[:, 0]) and np.median(D[:, -1]) < np.median(D[:, 0])),
              f"‖(α − α*)/α*‖: {np.median(D[:, 0]):.2f} before, {np.median(D[:, 1]):.2f} after the first, "
              f"{np.median(D[:, -1]):.2f} after the last adaptation (paper's first: "
              f"{alpha_distance(np.array(ct.EXPERIMENT_4_PAPER_FIRST)):.2f})"),
        Claim("s3-rqp-error", "the estimation error drops after adaptation",
              bool(np.mean(ra[later]) < np.mean(rf[later]) and np.mean(va[later]) <= np.mean(vf[later])),
              f"range RMS after t = 200 s {np.mean(ra[later]):.2f} m adapted vs {np.mean(rf[later]):.2f} m not; "
              f"velocity {np.mean(va[later]):.2f} vs {np.mean(vf[later]):.2f} m/s"),
        Claim("s3-rqp-likelihood", "every adaptation raises the window's likelihood",
              bool(np.all(nll[:, :, 1] <= nll[:, :, 0] + 1e-9)),
              f"median J {np.median(nll[:, 0, 0]):.1f} → {np.median(nll[:, 0, 1]):.1f} at the first"),
    ]
    s.lines += ["Findings:", "", *claims_lines(s.claims), "", *figure_links([figure], doc_dir), ""]
    return s


EXPERIMENT4_DISCUSSION = """\
**Differences.** Chaer et al. 1997 show one run, whose first adaptation lands within 10–30 % of α* in every
component (relative distance 0.30). navbank's runs scatter more widely (median relative distance 0.7–1.0 after
each adaptation): 200 measurements constrain the range process noise q1 weakly, and the maximum-likelihood α of
one window is itself that far from α*. The median of the first adaptations, though, is as close to α* as the
paper's single result, and the window likelihood, the distance to α* and the estimation error all improve. The
error improvement is modest (about 5 % in range, 3 % in velocity) because KF 1's Table IV parameters are already
within a factor of 5 of α* and the Kalman gain is insensitive to such a mis-tuning. The weight history matches
Fig. 10: KF 1 takes and keeps a weight near 1 after the first adaptation. The paper does not say to what the
covariances are re-initialised; navbank uses P₀⁻."""

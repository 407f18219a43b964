"""Chaer et al. 1997 §V.D (Experiment 4) on navbank's ``chaer-tracking`` scenario: RQP parameter
adaptation of the best filter (§IV, eqs. 21–23) every 200 s, starting from the Table IV bank.

Each seed flies 1000 measurements of the 2-state tracking example with α* (the paper's "actual
solution") as the truth and filters them twice with navbank's linear bank gated by ``moe`` (η = 1,
as in the paper): once with :class:`fsw.filters.rqp.LinearBankAdaptation` (window 200, SLSQP in
slices of 5 iterations per measurement, §V.D's restart of every filter from the best estimate with
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
    """Distance to α* in log space (every component counts by its ratio, not its size)."""
    return float(np.linalg.norm(np.log(np.maximum(alpha, 1e-3) / np.asarray(ct.EXPERIMENT_4_TRUTH))))


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


def run_experiment_4(runs: int = 20, length: int = LENGTH, example_seed: int = 0) -> Experiment4Results:
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


def plot_experiment_4(results: Experiment4Results, path: str | Path) -> Path:
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

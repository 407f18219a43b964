"""Chaer et al. 1997 §V (Chaer, Bishop & Ghosh 1997) on navbank's ``chaer-tracking`` scenario: the 2-state
tracking experiments run through navbank's own linear filter bank (``fsw.filters.linear``) and
gating networks (``magill``: Chaer et al. 1997 eqs. 7-8; ``moe``: eqs. 11-20), on measurements from
``sim.scenarios.chaer_tracking`` (Tables I-III, the five-segment Experiment 3).

Numbers computed (all medians over independent seeds):

* Experiments 1 and 2: the weight of KF 3 (the filter with the true parameters) after 100, 300
  and 1000 measurements, for Magill and for the gate at eta = 0.1, 1 and 7;
* Experiment 3: the delay, in measurements after each change, until the matching filter has the
  largest weight ("top") and until the previous filter has lost 10 % of its weight ("onset"), for
  Magill and the gate (eta 1 and 7); Magill with a 1e-3 lower bound (Hanlon & Maybeck 2000 §II.A.2);
* the measurement after which the literal product form of eqs. 7-8 underflows (Chaer et al. 1997: ~168).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fsw.filters.linear import LinearFilterBank
from fsw.filters.record import BankRecord
from fsw.gating import make_network
from fsw.gating.magill import direct_product_weights, chaer1997_log_density
from sim.scenarios import chaer_tracking as ct

NAMES = tuple(f"KF{i}" for i in range(1, 6))
CHECKPOINTS = (100, 300, 1000)
ETAS = (0.1, 1.0, 7.0)


def bank_records(z: np.ndarray, alpha: np.ndarray) -> list[BankRecord]:
    """Chaer et al. 1997 eqs. 2-6 for every row alpha = [q1 q2 r1 r2]; measurement 1 updates the a-priori
    state (no prediction before it), every later one follows one transition step."""
    alpha = np.asarray(alpha, dtype=float)
    n_f = len(alpha)
    Q = np.zeros((n_f, 2, 2))
    R = np.zeros((n_f, 2, 2))
    Q[:, 0, 0], Q[:, 1, 1], R[:, 0, 0], R[:, 1, 1] = alpha.T
    bank = LinearFilterBank(NAMES[:n_f], ct.TRANSITION, Q, ct.MEASUREMENT_MATRIX, R,
                            ct.FILTER_INITIAL_STATE, ct.FILTER_INITIAL_COVARIANCE)
    out = []
    for k, zk in enumerate(np.asarray(z, dtype=float)):
        rec = bank.update(zk, t=float(k), seq=k) if k == 0 else bank.step(zk, t=float(k), seq=k)
        out.append(BankRecord(rec.t, rec.seq, rec.kind, rec.filters, rec.residual.copy(), rec.S.copy(),
                              rec.chi2.copy(), rec.processed.copy(), rec.active_mask().copy()))
    return out


def weight_history(records: list[BankRecord], network: str, params: dict | None = None) -> np.ndarray:
    """(K, N) weights after each measurement."""
    net = make_network(network, records[0].filters, params or {})
    rows = []
    for r in records:
        upd = net.update(r)
        if upd is None:  # these networks update on every measurement
            raise ValueError(f"{network} gave no weights after measurement {r.seq}")
        rows.append(upd.weights)
    return np.array(rows)


@dataclass
class Chaer1997Results:
    selection: dict[int, dict[str, list[float]]] = field(default_factory=dict)  # experiment -> network -> KF3 weights
    delays_top: dict[str, list[float]] = field(default_factory=dict)  # network -> median delay per change
    delays_onset: dict[str, list[float]] = field(default_factory=dict)
    first_change_top_p10_p90: dict[str, list[float]] = field(default_factory=dict)
    magill_bound_delays: list[float] = field(default_factory=list)
    underflow: list[int] = field(default_factory=list)
    runs: dict[str, int] = field(default_factory=dict)
    example: dict[str, np.ndarray] = field(default_factory=dict)  # one Experiment 3 run's histories

    def as_dict(self) -> dict:
        return {"selection": self.selection, "delays_top": self.delays_top, "delays_onset": self.delays_onset,
                "first_change_top_p10_p90": self.first_change_top_p10_p90,
                "magill_bound_delays": self.magill_bound_delays, "underflow": self.underflow, "runs": self.runs}


def _label(network: str, eta: float | None = None) -> str:
    return network if eta is None else f"gate eta={eta:g}"


def run_chaer1997(selection_runs: int = 5, switching_runs: int = 60, underflow_runs: int = 10,
                example_seed: int = 0) -> Chaer1997Results:
    """All Chaer et al. 1997 numbers of the validation report (a few seconds per 10 runs)."""
    out = Chaer1997Results(runs={"selection": selection_runs, "switching": switching_runs, "underflow": underflow_runs})
    for experiment in (1, 2):
        acc: dict[str, list[np.ndarray]] = {}
        for seed in range(selection_runs):
            gen = ct.experiment_1 if experiment == 1 else ct.experiment_2
            run = gen(np.random.default_rng(seed), length=max(CHECKPOINTS))
            recs = bank_records(run.z, ct.bank_parameters(experiment))
            at = [c - 1 for c in CHECKPOINTS]
            acc.setdefault("magill", []).append(weight_history(recs, "magill")[at, 2])
            for eta in ETAS:
                acc.setdefault(_label("moe", eta), []).append(weight_history(recs, "moe", {"eta": eta})[at, 2])
        out.selection[experiment] = {k: np.median(np.array(v), axis=0).round(3).tolist() for k, v in acc.items()}

    top: dict[str, list[np.ndarray]] = {}
    onset: dict[str, list[np.ndarray]] = {}
    bound = []
    for seed in range(switching_runs):
        run = ct.experiment_3(np.random.default_rng(seed))
        recs = bank_records(run.z, ct.bank_parameters(3))
        hist = {"magill": weight_history(recs, "magill"),
                _label("moe", 1.0): weight_history(recs, "moe", {"eta": 1.0}),
                _label("moe", 7.0): weight_history(recs, "moe", {"eta": 7.0})}
        for k, W in hist.items():
            top.setdefault(k, []).append(ct.switch_delays(W))
            onset.setdefault(k, []).append(ct.switch_delays(W, rule="onset"))
        bound.append(ct.switch_delays(weight_history(recs, "magill", {"lower_bound": 1e-3})))
        if seed < underflow_runs:
            dead = direct_product_weights(np.array([chaer1997_log_density(r) for r in recs]))[1]
            out.underflow.append(-1 if dead is None else dead + 1)  # 1-based, as Chaer et al. 1997 counts
        if seed == example_seed:
            out.example = {**hist, "magill lower bound 1e-3": weight_history(recs, "magill", {"lower_bound": 1e-3})}
    for k in top:
        T, O = np.array(top[k]), np.array(onset[k])
        out.delays_top[k] = np.median(T, axis=0).tolist()
        out.delays_onset[k] = np.median(O, axis=0).tolist()
        out.first_change_top_p10_p90[k] = np.percentile(T[:, 0], [10, 90]).round(1).tolist()
    out.magill_bound_delays = np.median(np.array(bound), axis=0).tolist()
    return out


def plot_experiment_3(results: Chaer1997Results, path: str | Path) -> Path:
    """Weights of the five filters through the five Experiment 3 segments (one seed), one panel per
    network: the analogue of Chaer et al.'s (1997) Experiment 3 figures."""
    from ground.report.figure import new_figure, save

    hist = results.example
    fig, axes = new_figure(len(hist), 1, size=(10.0, 2.2 * len(hist)), sharex=True)
    for ax, (name, W) in zip(np.atleast_1d(axes), hist.items()):
        k = np.arange(1, len(W) + 1)
        for i in range(W.shape[1]):
            ax.plot(k, W[:, i], lw=1.2, label=NAMES[i])
        for c in range(1, len(W) // ct.EXPERIMENT_3_SEGMENT_LENGTH):
            ax.axvline(c * ct.EXPERIMENT_3_SEGMENT_LENGTH + 0.5, color="0.5", ls="--", lw=0.8)
        ax.set_ylabel("weight")
        ax.set_title(name, fontsize=10, loc="left")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].legend(ncol=5, fontsize=8, loc="upper right")
    np.atleast_1d(axes)[-1].set_xlabel("measurement (segment k uses the parameters of KF k; changes dashed)")
    return save(fig, Path(path))

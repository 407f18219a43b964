"""Chaer et al. 1997 §VIII (Chaer, Bishop & Ghosh 1997): GA tuning of a 20-filter bank on the 200
measurements of Experiment 4 (truth α* = [4.31 22.45 24.01 11.42]), Table VII and Fig. 15.

The measurement set is simulated by ``sim.scenarios.chaer_tracking`` (or read from a recording);
the GA is ``ground.tuning.ga`` and every generation re-processes the set through the FSW's linear
bank and ``moe`` gate (``ground.tuning.linear_bank``). Besides the paper's α* (the truth), the
maximum-likelihood α̂ of each simulated set is computed directly (scipy), since a finite set's
optimum is not the truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ground.tuning import ga, linear_bank as lb
from sim.scenarios import chaer_tracking as ct
from tools.validation.claims import Claim
from tools.validation.section import Section, claims_lines, figure_links, table

#: Chaer et al. 1997 §V.D / Table VII: the optimal α* and the best filters of the 1st and 18th iterations.
PAPER_OPTIMAL = (4.31, 22.45, 24.01, 11.42)
PAPER_BEST_FIRST = (2.34, 18.58, 8.66, 11.71)
PAPER_BEST_18TH = (6.22, 20.45, 24.18, 11.66)
PAPER_ITERATIONS = 18
EXPERIMENT_4_LENGTH = 200
PARAMS = ("q1", "q2", "r1", "r2")


def experiment_4(seed: int, length: int = EXPERIMENT_4_LENGTH) -> np.ndarray:
    """(K, 2) measurements of a stationary sequence with the truth α* (Chaer et al. 1997 §V.D)."""
    return ct.generate([PAPER_OPTIMAL], length, np.random.default_rng(seed)).z


def ml_optimum(z: np.ndarray, start: Sequence[float] = PAPER_OPTIMAL) -> np.ndarray:
    """α̂ maximising the measurement set's log-likelihood under one filter (Nelder-Mead on ln α)."""
    from scipy.optimize import minimize

    def cost(log_alpha: np.ndarray) -> float:
        return -float(lb.log_likelihood(z, np.exp(log_alpha)[None, :])[0])

    res = minimize(cost, np.log(np.asarray(start, dtype=float)), method="Nelder-Mead",
                   options={"xatol": 1e-4, "fatol": 1e-6, "maxiter": 4000})
    return np.exp(res.x)


def bank_fitness(z: np.ndarray, eta: float, mapper: lb.Mapper = map, chunks: int = 1) -> ga.Fitness:
    """Chaer et al. 1997 §VIII fitness: the gate's weights after the last measurement of the set."""

    def fitness(params: np.ndarray) -> np.ndarray:
        return lb.gate_weights(lb.bank_records(z, params, mapper=mapper, chunks=chunks), eta)[-1]

    return fitness


@dataclass
class GaRun:
    data_seed: int
    ga_seed: int
    eta: float
    result: ga.GaResult
    ml: np.ndarray  # α̂ of the set
    loglik: dict[str, float]  # log-likelihood of the set under: truth, ml, best first, best final

    def as_dict(self) -> dict:
        r = self.result
        return {"data_seed": self.data_seed, "ga_seed": self.ga_seed, "eta": self.eta,
                "iterations": len(r.generations), "converged": r.converged,
                "best_first": r.generations[0].best.round(3).tolist(), "best_final": r.final.best.round(3).tolist(),
                "ml": self.ml.round(3).tolist(), "loglik": {k: round(v, 3) for k, v in self.loglik.items()},
                "settings": vars(r.settings), "coding": vars(r.coding),
                "generations": [g.as_dict() for g in r.generations]}


def run_one(z: np.ndarray, eta: float, ga_seed: int, *, data_seed: int = -1, settings: ga.GaSettings | None = None,
            coding: ga.Coding | None = None, mapper: lb.Mapper = map, chunks: int = 1,
            on_generation: Callable[[ga.Generation], None] | None = None) -> GaRun:
    settings = settings or ga.GaSettings()
    coding = coding or ga.Coding()
    res = ga.run_ga(bank_fitness(z, eta, mapper, chunks), coding, settings, np.random.default_rng(ga_seed),
                    on_generation=on_generation)
    ml = ml_optimum(z)
    ll = lb.log_likelihood(z, np.array([PAPER_OPTIMAL, ml, res.generations[0].best, res.final.best]))
    return GaRun(data_seed, ga_seed, eta, res, ml, dict(zip(("truth", "ml", "best_first", "best_final"), map(float, ll))))


def run_campaign(seeds: Sequence[int] = tuple(range(8)), etas: Sequence[float] = (1.0, 7.0)) -> list[GaRun]:
    """One GA per (η, seed) on Experiment 4 sets: data seed s, GA seed 1000 + s (~1 s each)."""
    return [run_one(experiment_4(s), eta, 1000 + s, data_seed=s) for eta in etas for s in seeds]


def plot_clusters(run: GaRun, path: str | Path) -> Path:
    """Fig. 15 analogue: the bank's (q1, q2) and (r1, r2) at the first and the last iteration, marker
    area by gating weight, the truth α* (*) and the set's maximum-likelihood α̂ (+)."""
    from ground.report.figure import new_figure, save

    gens = [run.result.generations[0], run.result.final]
    fig, axes = new_figure(2, 2, size=(9.0, 8.0))
    for row, g in enumerate(gens):
        for col, (i, j, lab) in enumerate(((0, 1, "q"), (2, 3, "r"))):
            ax = axes[row, col]
            w = g.fitness / max(float(g.fitness.max()), 1e-12)
            ax.scatter(g.params[:, i], g.params[:, j], s=15 + 250 * w, marker="o", facecolors="none",
                       edgecolors="C0", label="filters (area ~ weight)")
            ax.plot(*PAPER_OPTIMAL[i:j + 1], "r*", ms=14, label="α* (truth)")
            ax.plot(run.ml[i], run.ml[j], "k+", ms=12, mew=2, label="α̂ (max. likelihood of the set)")
            ax.set_xlim(0, 51)
            ax.set_ylim(0, 51)
            ax.set_xlabel(f"{lab}1")
            ax.set_ylabel(f"{lab}2")
            ax.set_title(f"iteration {g.iteration}: {'Q' if lab == 'q' else 'R'}", fontsize=10, loc="left")
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right")
    return save(fig, Path(path))


CLUSTER_RADIUS = 5.0


def near_optimum(run: GaRun, generation: ga.Generation) -> int:
    """Filters of a generation within ``CLUSTER_RADIUS`` of the set's α̂ (clipped to the search
    interval) in every component: the Fig. 15 clustering, counted."""
    c = run.result.coding
    target = np.clip(run.ml, c.lower, c.upper)
    return int(np.sum(np.all(np.abs(generation.params - target) <= CLUSTER_RADIUS, axis=1)))


def _v(x: Sequence[float] | np.ndarray) -> str:
    return "[" + " ".join(f"{float(a):.2f}" for a in x) + "]"


def ga_section(runs: list[GaRun], fig_dir: Path, doc_dir: Path) -> Section:
    s = Section("Chaer et al. 1997 §VIII: GA tuning of the bank on post-processed data (Table VII, Fig. 15)")
    etas = sorted({r.eta for r in runs})
    seeds = sorted({r.data_seed for r in runs})
    by = {eta: [r for r in runs if r.eta == eta] for eta in etas}
    ex = {eta: by[eta][0] for eta in etas}
    s.lines += [
        f"`navbank tune ga` on {len(seeds)} simulated {EXPERIMENT_4_LENGTH}-measurement sets of Experiment 4 "
        f"(truth α* = {_v(PAPER_OPTIMAL)}), a bank of 20 filters, l = 10 bits per parameter on [1, 50] (eq. 33), "
        "fitness = the `moe` gate's weights after the last measurement, roulette selection, crossover at "
        "parameter boundaries (p_c 0.9), mutation (p_m 0.02 per bit), elitism, ε = 2, at most 30 iterations; "
        "at the paper's η = 1 and at η = 7. Each generation re-processes the whole set through the FSW's "
        "linear bank. Table VII beside the first set's runs (α̂ = the set's maximum-likelihood parameters):",
        "",
    ]
    rows = [["optimal α* (truth)", _v(PAPER_OPTIMAL), _v(PAPER_OPTIMAL), ""],
            ["α̂ of the set (max. likelihood)", "—", _v(ex[etas[0]].ml), ""],
            ["best, 1st iteration", _v(PAPER_BEST_FIRST), _v(ex[etas[0]].result.generations[0].best), ""]]
    for eta in etas:
        r = ex[eta]
        rows.append([f"best, last iteration (η = {eta:g})", f"{_v(PAPER_BEST_18TH)} (18th)",
                     f"{_v(r.result.final.best)} ({len(r.result.generations)}th)",
                     "converged" if r.result.converged else "not converged"])
    s.lines += table(["α = [q1 q2 r1 r2]", "Chaer et al. 1997", "navbank", "ε test"], rows)
    s.lines += ["", "Over all sets (log-likelihood of the set relative to α̂'s, nat; medians):", ""]
    agg = []
    for eta in etas:
        rs = by[eta]
        gain = [r.loglik["best_final"] - r.loglik["best_first"] for r in rs]
        agg.append([f"{eta:g}", f"{sum(r.result.converged for r in rs)}/{len(rs)}",
                    f"{np.median([len(r.result.generations) for r in rs]):.0f}",
                    f"{np.median([r.loglik['best_first'] - r.loglik['ml'] for r in rs]):.1f}",
                    f"{np.median([r.loglik['best_final'] - r.loglik['ml'] for r in rs]):.1f}",
                    f"{np.median([r.loglik['truth'] - r.loglik['ml'] for r in rs]):.1f}",
                    f"{sum(g > 0 for g in gain)}/{len(rs)}",
                    f"{np.median([near_optimum(r, r.result.generations[0]) for r in rs]):.0f} → "
                    f"{np.median([near_optimum(r, r.result.final) for r in rs]):.0f}",
                    f"{np.median([float(np.max(r.result.final.fitness)) for r in rs]):.2f}"])
    s.lines += table(["η", "converged (ε = 2)", "iterations", "best 1st", "best last", "truth α*",
                      "last beats 1st", f"filters within {CLUSTER_RADIUS:g} of α̂ (1st → last)",
                      "top weight at the end"], agg)
    figs = [plot_clusters(ex[eta], fig_dir / f"chaer1997-ga-clusters-eta{eta:g}.png") for eta in etas]
    s.lines += ["", *figure_links(figs, doc_dir), ""]
    best = max(etas)
    rs = by[best]
    improved = sum(r.loglik["best_final"] > r.loglik["best_first"] for r in rs)
    near = [r.loglik["best_final"] - r.loglik["ml"] for r in rs]
    conv = {eta: sum(r.result.converged for r in by[eta]) for eta in etas}
    n_near = [near_optimum(r, r.result.final) for r in rs]
    s.claims = [
        Claim("ga-improves", f"the GA's best filter improves on the 1st iteration's (η = {best:g})",
              improved >= 0.75 * len(rs),
              f"better log-likelihood of the set in {improved}/{len(rs)} runs; final best a median "
              f"{np.median(near):.1f} nat from α̂'s"),
        Claim("ga-clusters", f"the bank clusters around the set's optimum (Fig. 15; η = {best:g})",
              float(np.median(n_near)) >= 10,
              f"a median {np.median(n_near):.0f} of 20 filters within {CLUSTER_RADIUS:g} of α̂ in every "
              f"component at the last iteration (1st: {np.median([near_optimum(r, r.result.generations[0]) for r in rs]):.0f})"),
        Claim("ga-converges", "the bank clusters within ε = 2 around the optimum (Fig. 15, 18 iterations)",
              all(conv[e] >= 0.5 * len(by[e]) for e in etas),
              ", ".join(f"η = {e:g}: {conv[e]}/{len(by[e])} runs met the ε test within 30 iterations" for e in etas)),
    ]
    s.lines += claims_lines(s.claims)
    return s


GA_DISCUSSION = """**Differences.** The fitness is the gate's weight after the last measurement, and with
navbank's `moe` gate (φ = [1], see `fsw.gating.moe` for why not the raw z) at the paper's η = 1 those
weights stay close to 1/20 after 200 measurements (top weight ~0.07): the selection is then nearly
uniform and the GA is close to a random search, which still improves the best filter but forms no
cluster. At η = 7 the bank gathers towards the set's maximum-likelihood α̂ rather than the truth α*
(the two differ by several units in q1 and r1 on 200 measurements; the paper's optimum is the truth),
about a third of it within 5 of α̂ in every component (the figure), and the best filter reaches the
likelihood of the truth; half the bank within 5, our reading of Fig. 15, is not reached. The stopping test is what fails:
with every weight near 1/20 every filter is "non-negligible" (> 1 %), and the few mutants each
generation makes keep the spread above ε = 2. Larger η (≥ 12) makes one filter take all the weight within the first iterations and
the GA stops on a cluster of near-copies of it, often far from α̂ (premature convergence). The paper's own
18th-iteration best is 1.9 from α* in q1 and 2.0 in q2, i.e. at the edge of its ε."""

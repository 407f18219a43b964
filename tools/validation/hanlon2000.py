"""Hanlon & Maybeck 2000 on navbank's linear actuator-failure cases: identification time of a failed
actuator against the dither amplitude, for the magnitude-based bank (``magill``, the MMAE rule on
residual magnitudes, Hanlon & Maybeck's "SKFB") and the residual-correlation bank
(``residual-correlation``, the periodogram statistic at the dither frequencies, eqs. 18–22, their
"RCKFB"), all over navbank's linear filter bank with the same lower bound on the probabilities (1e-3).

Two cases (:mod:`sim.scenarios.dither_case`): the two-axis, three-actuator model at 100 Hz
(``sim.scenarios.actuator_dither``) and the spacecraft with four reaction wheels at 10 Hz
(``sim.scenarios.wheel_dither``). Two residual-correlation variants: as the paper runs it
(probabilities updated on every sample from overlapping windows, eq. 21's Gaussian density) and
with each window's evidence counted once (disjoint windows, ``update_every = N``, the exact
exponential density of the periodogram of white residuals).

Declaration (the paper's rule, §III.A): a hypothesis is declared while its probability is above 0.5.
Identification time: from the failure to the last time the failed actuator's hypothesis crosses 0.5
and stays above it to the end of the run (None: not declared at the end). False alarm: a failure
declared in nominal operation once every bank is running (from the end of the first window to the
failure; before it the magnitude bank's first few samples, with every filter still at its prior, would
count start-up noise the residual-correlation bank cannot show). Wrong declaration: after the failure,
another actuator's failure declared.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fsw.filters.linear import LinearFilterBank
from fsw.gating import make_network
from sim.scenarios import actuator_dither, wheel_dither
from sim.scenarios.dither_case import DitherCase, DitherRun
from tools.validation.claims import Claim
from tools.validation.section import Section, claims_lines, figure_links, table

MULTIPLIERS = (1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01)
WINDOW = 100  # N, as the paper
THRESHOLD = 0.5  # the paper's declaration threshold
FAIL_AT = 400  # samples of nominal operation before the failure (three windows)
LENGTH = 1400  # 1000 samples after it (the paper's runs end 7 s = 700 samples after the failure)
LOWER_BOUND = 1e-3
CASES: dict[str, DitherCase] = {"two-axis": actuator_dither.CASE, "spacecraft": wheel_dither.CASE}
#: label -> (network, parameters apart from the frequencies)
NETWORKS: dict[str, tuple[str, dict[str, Any]]] = {
    "magill": ("magill", {"lower_bound": LOWER_BOUND}),
    "rc per sample": ("residual-correlation", {"window": WINDOW, "lower_bound": LOWER_BOUND}),
    "rc disjoint": ("residual-correlation", {"window": WINDOW, "lower_bound": LOWER_BOUND,
                                             "update_every": WINDOW, "density": "exponential"}),
}
RC_PAPER, RC_ONCE = "rc per sample", "rc disjoint"


def make_networks(case: DitherCase) -> dict[str, Any]:
    out = {}
    for label, (kind, params) in NETWORKS.items():
        p = dict(params)
        if kind == "residual-correlation":
            p["frequencies"] = case.frequencies
        out[label] = make_network(kind, case.hypotheses, p)
    return out


def weights(case: DitherCase, run: DitherRun, amplitude: float) -> dict[str, np.ndarray]:
    """(K, hypotheses) weights of each network on one run (the last update held between updates)."""
    mats = case.bank_matrices(amplitude)
    bank = LinearFilterBank(case.hypotheses, mats["F"], mats["Q"], mats["H"], mats["R"], mats["x0"], mats["P0"])
    nets = make_networks(case)
    uniform = np.full(len(case.hypotheses), 1.0 / len(case.hypotheses))
    last = {name: uniform for name in nets}
    out: dict[str, list[np.ndarray]] = {name: [] for name in nets}
    for k, z in enumerate(run.z):
        rec = bank.update(z, t=k * case.dt, seq=k) if k == 0 else bank.step(z, t=k * case.dt, seq=k)
        for name, net in nets.items():
            upd = net.update(rec)
            if upd is not None:
                last[name] = np.asarray(upd.weights)
            out[name].append(last[name])
    return {name: np.array(v) for name, v in out.items()}


@dataclass(frozen=True)
class Outcome:
    samples: int | None  # failure to identification (None: not declared at the end)
    false_alarm: bool  # a failure declared before the failure
    wrong: bool  # another failure declared after it


def identification(W: np.ndarray, failed: int, fail_at: int, start: int = WINDOW) -> Outcome:
    """The paper's declaration rule applied to one run's (K, hypotheses) weights; false alarms are
    counted from sample ``start``."""
    declared = W > THRESHOLD
    false_alarm = bool(declared[start:fail_at, 1:].any())
    others = [j for j in range(1, W.shape[1]) if j != failed]
    wrong = bool(declared[fail_at:, others].any())
    held = declared[fail_at:, failed]
    if not held[-1]:
        return Outcome(None, false_alarm, wrong)
    below = np.flatnonzero(~held)
    return Outcome(0 if len(below) == 0 else int(below[-1]) + 1, false_alarm, wrong)


@dataclass
class Hanlon2000Results:
    case: str
    dt: float
    runs: int = 0
    time_s: dict[str, dict[float, list[float | None]]] = field(default_factory=dict)  # network -> multiplier -> runs
    false: dict[str, dict[float, int]] = field(default_factory=dict)  # runs with a false alarm
    wrong: dict[str, dict[float, int]] = field(default_factory=dict)  # runs with a wrong declaration

    @property
    def multipliers(self) -> list[float]:
        return sorted(self.time_s["magill"], reverse=True)

    def identified(self, network: str, mult: float) -> int:
        return sum(x is not None for x in self.time_s[network][mult])

    def median_s(self, network: str, mult: float) -> float | None:
        """Median identification time [s]; None when half the runs or more never identify."""
        v = self.time_s[network][mult]
        if self.identified(network, mult) * 2 <= len(v):
            return None
        return float(np.median([x if x is not None else np.inf for x in v]))

    def smallest(self, network: str) -> float | None:
        """Smallest multiplier at which the network identifies the failure in more than half the runs
        with no false alarm or wrong declaration in any run; None if no multiplier qualifies."""
        ok = [m for m in self.multipliers if self.median_s(network, m) is not None
              and self.false[network][m] == 0 and self.wrong[network][m] == 0]
        return min(ok) if ok else None


def run_hanlon2000(case: str = "two-axis", runs: int = 12,
                   multipliers: tuple[float, ...] = MULTIPLIERS) -> Hanlon2000Results:
    c = CASES[case]
    out = Hanlon2000Results(case=case, dt=c.dt, runs=runs,
                            time_s={n: {m: [] for m in multipliers} for n in NETWORKS},
                            false={n: {m: 0 for m in multipliers} for n in NETWORKS},
                            wrong={n: {m: 0 for m in multipliers} for n in NETWORKS})
    for mult in multipliers:
        for seed in range(runs):
            failed = 1 + seed % c.n_act
            run = c.generate(np.random.default_rng(seed), c.amplitude * mult, failed, FAIL_AT, LENGTH)
            for name, W in weights(c, run, c.amplitude * mult).items():
                o = identification(W, failed, FAIL_AT)
                out.time_s[name][mult].append(None if o.samples is None else round(o.samples * c.dt, 9))
                out.false[name][mult] += int(o.false_alarm)
                out.wrong[name][mult] += int(o.wrong)
    return out


def plot_hanlon2000(r: Hanlon2000Results, path: Path) -> Path:
    """Median identification time against the dither multiplier (Figs. 7–9 analogue); a dashed
    segment where a run had a false alarm or a wrong declaration (the paper's dashes)."""
    from ground.report.figure import new_figure, save

    fig, ax = new_figure(1, 1, size=(7.0, 4.0))
    mults = r.multipliers
    for name, marker in zip(NETWORKS, ("x", "o", "s")):
        y = np.array([np.nan if (v := r.median_s(name, m)) is None else v for m in mults])
        bad = np.array([r.false[name][m] + r.wrong[name][m] > 0 for m in mults])
        (line,) = ax.plot(mults, y, marker + "--")
        ax.plot(mults, np.where(bad, np.nan, y), marker + "-", color=line.get_color(), label=name)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.invert_xaxis()
    ax.set_xlabel("dither amplitude multiplier")
    ax.set_ylabel("median identification time [s]")
    ax.set_title(f"{CASES[r.case].name}\ndashed: a run had a false alarm or wrong declaration; "
                 "missing: identified in half the runs or fewer", fontsize=8)
    ax.legend(fontsize=8)
    return save(fig, path)


def _case_text(r: Hanlon2000Results) -> str:
    c = CASES[r.case]
    if r.case == "two-axis":
        return ("`sim.scenarios.actuator_dither`: two-axis attitude at 100 Hz, three actuators each dithered at its "
                "own known frequency, 0.05 / 0.08 / 0.11 cycles per sample; the paper's sample rate and window")
    return ("`sim.scenarios.wheel_dither`: a ~500 kg spacecraft holding inertial attitude (J = diag(400, 350, 250) "
            "kg m²), four reaction wheels in the standard pyramid, each with a 0.02 N m torque dither at 0.5 / 0.8 / "
            "1.1 / 1.4 Hz (0.05 / 0.08 / 0.11 / 0.14 cycles per sample at the 10 Hz control rate), gyro (5e-6 rad/s) "
            f"and star tracker (10 arcsec) at 10 Hz; the N = {WINDOW} window spans {WINDOW * c.dt:g} s")


def hanlon2000_section(r: Hanlon2000Results, figure: Path, doc_dir: Path) -> Section:
    c = CASES[r.case]
    s = Section(f"Hanlon & Maybeck 2000: residual correlation against residual magnitude, {c.name}")
    mults = r.multipliers
    s.lines += [
        f"Hanlon & Maybeck 2000's question on navbank's {c.name} case ({_case_text(r)}). Hypotheses: nominal and "
        f"one per failed actuator; navbank's linear bank. The failure comes after {FAIL_AT} samples "
        f"({FAIL_AT * c.dt:g} s) and the run goes on {LENGTH - FAIL_AT} samples. The paper's declaration rule: a "
        f"hypothesis is declared while its probability exceeds {THRESHOLD}; identification time runs from the failure "
        "to the last crossing after which the failed actuator's hypothesis stays declared; a false alarm is a failure "
        f"declared in nominal operation once every bank runs (samples {WINDOW} to {FAIL_AT}), a wrong declaration "
        "another actuator's failure declared after the failure. Three banks "
        f"share the filters and the {LOWER_BOUND:g} lower bound: `magill` (the MMAE rule on residual magnitudes, the "
        f"paper's SKFB); `{RC_PAPER}` (eqs. 18–22 as the paper runs them: the periodogram of the normalised residuals "
        f"at the dither frequencies, N = {WINDOW}, eq. 21's Gaussian with the analytic white-residual mean and "
        f"covariance, probabilities updated on every sample); `{RC_ONCE}` (the same statistic with "
        f"`update_every: {WINDOW}` and `density: exponential`: disjoint windows, each counted once with the exact "
        f"density of the periodogram of white residuals). {r.runs} runs per multiplier, each actuator failing in turn.",
        "",
        "Computed by `navbank validation-report` itself (well under a minute).",
        "",
    ]
    rows = []
    for mlt in mults:
        row = [f"{mlt:g}"]
        for name in NETWORKS:
            med = r.median_s(name, mlt)
            row.append(f"{r.identified(name, mlt)}/{r.runs}" + (f", {med:.2f} s" if med is not None else "")
                       + f"; {r.false[name][mlt]} / {r.wrong[name][mlt]}")
        rows.append(row)
    s.lines += table(["dither multiplier"] + [f"{n}: identified, median time; false alarms / wrong" for n in NETWORKS],
                     rows)
    s.lines += [""]
    s.claims = hanlon2000_claims(r)
    s.lines += ["Findings:", "", *claims_lines(s.claims), "", *figure_links([figure], doc_dir), ""]
    return s


def _smallest_identified(r: Hanlon2000Results, network: str) -> float | None:
    """Smallest multiplier at which the network identifies the failure in more than half the runs."""
    ok = [m for m in r.multipliers if r.median_s(network, m) is not None]
    return min(ok) if ok else None


def _s(seconds: float | None) -> str:
    return "n/a" if seconds is None else f"{seconds:.2f} s"


def _bad(r: Hanlon2000Results, network: str, mult: float) -> int:
    return r.false[network][mult] + r.wrong[network][mult]


def hanlon2000_claims(r: Hanlon2000Results) -> list[Claim]:
    c = CASES[r.case]
    top, low = max(r.multipliers), min(r.multipliers)
    sm = {n: _smallest_identified(r, n) for n in NETWORKS}
    ev_sm = "smallest multiplier identified in over half the runs: " + ", ".join(f"{n} {sm[n]}" for n in NETWORKS)

    def below(n: str) -> bool:
        mine, magill = sm[n], sm["magill"]
        return mine is not None and (magill is None or mine < magill)

    mag1, rc1 = r.median_s("magill", top), r.median_s(RC_PAPER, top)
    delay = None if mag1 is None or rc1 is None else rc1 - mag1
    window_s = WINDOW * c.dt
    first = [x for x in r.time_s[RC_PAPER][top] if x is not None]
    tiny = [m for m in r.multipliers if m <= 0.02]
    bad_tot = {n: sum(_bad(r, n, m) for m in r.multipliers) for n in NETWORKS}
    return [
        Claim(f"hm-small-{r.case}", f"{r.case}: the residual-correlation bank, run as the paper runs it, identifies "
              "failures at smaller dither than the magnitude-based bank (Figs. 7–9)", below(RC_PAPER), ev_sm),
        Claim(f"hm-small-once-{r.case}", f"{r.case}: so does it with each window's evidence counted once",
              below(RC_ONCE), ev_sm),
        Claim(f"hm-chance-{r.case}", f"{r.case}: what the per-sample bank identifies at multipliers ≤ 0.02 comes with a "
              "wrong declaration (another actuator's failure) in every run: chance, not detection",
              bool(tiny) and all(r.wrong[RC_PAPER][m] == r.runs for m in tiny),
              "; ".join(f"×{m:g}: identified {r.identified(RC_PAPER, m)}/{r.runs}, false alarms "
                        f"{r.false[RC_PAPER][m]}, wrong declarations {r.wrong[RC_PAPER][m]}" for m in tiny)
              + " (`magill` identified " + ", ".join(str(r.identified("magill", m)) for m in tiny) + ")"),
        Claim(f"hm-window-{r.case}", f"{r.case}: the periodogram window delays identification: never within 0.3 N·Δt "
              f"= {0.3 * window_s:g} s of the failure at full dither (paper: half the N samples must carry the "
              "sinusoid first)", bool(first) and min(first) >= 0.3 * window_s,
              f"{RC_PAPER} earliest {_s(min(first) if first else None)}, median {_s(rc1)}; `magill` median {_s(mag1)}"),
        Claim(f"hm-slower-{r.case}", f"{r.case}: at full dither the residual-correlation bank is slower than the "
              f"magnitude bank by about the window, N·Δt = {window_s:g} s (paper: ~1 s for N = 100 at 100 Hz)",
              delay is not None and 0.3 * window_s <= delay <= 1.5 * window_s,
              f"{RC_PAPER} median {_s(rc1)}, `magill` {_s(mag1)} at multiplier {top:g}: difference {_s(delay)}"),
        Claim(f"hm-false-{r.case}", f"{r.case}: false alarms and wrong declarations appear as the dither decreases "
              "(paper: dashed segments of Figs. 7–9), none at full dither for the residual-correlation bank",
              _bad(r, RC_PAPER, top) == 0 and _bad(r, RC_PAPER, low) > 0,
              f"runs with a false alarm + runs with a wrong declaration at multiplier {top:g} / {low:g}: "
              + ", ".join(f"{n} {_bad(r, n, top)} / {_bad(r, n, low)}" for n in NETWORKS)),
        Claim(f"hm-once-{r.case}", f"{r.case}: counting each window once (disjoint windows, exact density) removes "
              "most of the per-sample bank's false alarms and wrong declarations",
              bad_tot[RC_ONCE] * 2 <= bad_tot[RC_PAPER],
              "over all multipliers: " + ", ".join(f"{n} {bad_tot[n]}" for n in NETWORKS)
              + f" (of {2 * r.runs * len(r.multipliers)} possible)"),
    ]


HANLON2000_DISCUSSION = """\
**What the false declarations are, and why the paper's Figs. 7–9 are not reproduced.** Run as the paper runs it,
the residual-correlation bank declares falsely in most runs below half dither (a first version of this section,
with a 0.9 threshold held for 50 samples, counted 26 of 42 runs). The declarations are false in the paper's
sense — a failure declared in nominal operation, or the wrong actuator's failure declared after one failed — and
they have two causes, one in the estimation and one in the case:

* *The estimation: each residual counted about N times.* Run as the paper runs it, the bank updates the probabilities on
  every sample (eq. 17) from windows that share N − 1 samples, as if each window's ψ were new evidence. A random
  excursion of the periodogram of a correct filter (each component is an exponential variable of mean 1 under its
  own hypothesis, so ψ = 5 happens in 0.7 % of windows) then persists over ~N updates and moves the probabilities
  ~N times as far as its evidence warrants; the 1e-3 lower bound makes every hypothesis win back within a few
  samples, so the probabilities swing between hypotheses. The periodogram itself is right (it equals numpy's FFT
  at the Fourier bins, and its analytic white-noise mean and covariance match Monte Carlo —
  `tests/test_gating_residual_correlation.py`). `update_every: N` (the paper's "propagating several time samples
  before updating") with `density: exponential` (the exact density of ψ under a correct filter, which the paper
  noticed looked "more chi-squared distributed") counts each window once; the `rc disjoint` column shows what
  that removes.
* *Not the window.* With N = 50 / 100 / 200 (two-axis, 6 runs each) the per-sample bank identifies at full dither
  in a median 0.25 / 0.52 / 0.97 s — about N/2 samples, the paper's "at least half of the N samples" — and still
  declares falsely in 6/6, 6/6 and 4/6 runs at a multiplier of 0.2; the multiplier below which neither bank
  identifies (about 0.05) does not move with N.
* *The case: below a multiplier of about 0.05 the failure is not identifiable by any statistic.* The excess of ψ
  at the dither frequency grows with the square of the dither: here about 40–100 (two-axis) and 35–210 (spacecraft)
  at full dither, so 0.003–0.02 at a multiplier of 0.01, against a statistic of unit mean and unit standard
  deviation; over the 1000 samples after the failure even a coherent matched filter collects less than one
  standard deviation of evidence. The identifications the per-sample bank reports there (and the earlier
  section's "5/6 at 0.01") come with a wrong declaration in every run: the hypotheses take turns above 0.5 and
  the run happens to end on the right one. The magnitude-based bank is no worse: in a bank whose filters differ
  only in their input columns (the same gains), the log-likelihood ratio of two hypotheses in eq. 17 is the
  correlation of the residual with the known difference of their predicted signatures — already a coherent
  matched filter at the dither frequency, which the (non-coherent) periodogram cannot beat. With each window
  counted once the two banks identify down to the same multiplier.

The paper's RCKFB held its identification time "fairly constant" down to a multiplier of 0.01; with ψ's excess
scaling as the dither squared, that is not reproducible on a linear bank unless the full dither leaves a
residual signature some 10⁴ times the noise floor (the paper's Fig. 5 shows about 40) or the declarations are
chance, which its dashed (false-alarm) segments and two Monte Carlo runs per point do not exclude. What does
reproduce: the window delay (the residual-correlation bank needs about half a window of sinusoid before ψ rises,
so it is slower than the magnitude bank at full dither on the two-axis case, ~N·Δt/3 here against the paper's
~1 s), and false alarms that rise as the dither falls. On the spacecraft the magnitude bank's median at full
dither is later than at half of it, but not for the paper's rudder reason (a slowly decaying residual): its
argmax is the failed wheel within the first seconds in every run examined; what dates identification late is
a momentary wrong declaration tens of seconds on. With strong dither one sample's likelihood ratio is large, and
the 1e-3 lower bound lets a hypothesis climb back above 0.5 on one or two such samples; the paper's rule (the
last crossing) then dates identification after the last flip. The residual-correlation bank, whose statistic
moves only as the window slides, shows no such flip at full dither.
The comparison is on navbank's linear attitude models, not the paper's aircraft; the spacecraft case keeps the
bank linear (small-angle inertial hold, gyroscopic coupling neglected) rather than using the EKF bank."""

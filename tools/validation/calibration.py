"""Validation section: how the shipped detector thresholds were calibrated and how they hold out of sample.

It reads the record ``navbank calibrate --plan NAME --report campaigns/calibration-NAME.json`` writes
(:mod:`tools.calibration.record`): per network, the in-sample calibration report and the held-out
check, and draws the held-out false-alarm counts against the intervals the calibrations predicted.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tools.calibration.record import CalibrationRecord, read_record
from tools.validation.claims import Claim
from tools.validation.section import Section, claims_lines, table

PLANS = ("insight-approach", "insight-thrusters", "insight-process-noise")
#: where each plan's detectors are shipped
SHIPPED = {"insight-approach": "the chi2 detector in `tools/scenarios/insight-approach.yaml` (onboard) and all three "
                               "in `tools/campaigns/detectors/` (the detection-matrix campaign's monitors)",
           "insight-thrusters": "`fsw.detector` of `tools/scenarios/insight-thrusters.yaml`",
           "insight-process-noise": "`fsw.detector` of `tools/scenarios/insight-process-noise.yaml`"}


def file_name(plan: str) -> str:
    return f"calibration-{plan}.json"


def command(plan: str) -> str:
    return f"navbank calibrate --plan {plan} --out-dir calibrations/{plan} --report campaigns/{file_name(plan)}"


def plot(rec: CalibrationRecord, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nets = [n for n in rec.networks if n.holdout is not None]
    x = np.arange(len(nets))
    fig, ax = plt.subplots(figsize=(8.5, 3.6))
    for i, n in enumerate(nets):
        h = n.holdout
        assert h is not None
        lo, hi = (100.0 * v / h.units for v in h.predicted)
        ax.fill_between([i - 0.3, i + 0.3], lo, hi, color="tab:blue", alpha=0.25,
                        label="predicted (95 %)" if i == 0 else None)
        ax.errorbar([i], [100 * h.rate], yerr=[[100 * (h.rate - h.ci[0])], [100 * (h.ci[1] - h.rate)]], fmt="o",
                    color="black", capsize=4, label="held out (95 % Clopper-Pearson)" if i == 0 else None)
        ax.plot([i - 0.3, i + 0.3], [100 * n.report.fa_rate] * 2, color="tab:orange",
                label="in sample" if i == 0 else None)
    ax.axhline(100 * rec.plan.target_fa, color="grey", linestyle="--", label=f"target {100 * rec.plan.target_fa:g} %")
    ax.set_xticks(x, [n.network for n in nets])
    ax.set_ylabel("false alarms per 45-day run [%]")
    ax.set_title(f"{rec.plan.scenario}: {rec.networks[0].runs} calibration runs, "
                 f"{nets[0].holdout_runs if nets else 0} held out")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside the bars, never over them
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def section(plan: str, path: Path, fig_dir: Path, doc_dir: Path) -> Section:
    rec = read_record(path)
    p = rec.plan
    s = Section(f"Detector calibration: the shipped thresholds of `{p.scenario}` and a held-out false-alarm check")
    cal, held = p.calibration_seeds(), p.holdout_seeds()
    s.lines += [
        f"The detectors on {', '.join(p.networks)} are calibrated on {p.seeds} nominal runs (seeds "
        f"{cal.start}–{cal.stop - 1}, no fault, detector off) for a {100 * p.target_fa:g} % false-alarm probability "
        f"per run, with a {p.persistence[0]}-of-{p.persistence[1]} persistence rule on the {p.statistic} deviation "
        f"of the weights from their nominal band (`tools/calibration/thresholds.py`: the threshold is the j-th "
        f"largest per-run critical value, j = ⌊α(R+1)⌋). Then {p.holdout} more nominal runs (seeds "
        f"{held.start}–{held.stop - 1}), which the calibration never saw, go through the real detector "
        "(`fsw.fdir.AnomalyDetector`). Their false-alarm count is not binomial around the target: the threshold "
        "is itself an order statistic, so the count of fresh runs above it is beta-binomial(M, j, R + 1 − j), and "
        "that 95 % prediction interval is what the held-out count must fall in. The plan is a built-in file "
        f"(`tools/campaigns/calibrations/{plan}.yaml`); calibrated on {rec.generated}. The detectors it writes "
        f"(`detector-NETWORK.yaml`) are shipped as {SHIPPED.get(plan, 'the scenario detector')}.",
        "",
        "```bash",
        command(plan),
        "```",
        "",
    ]
    body = []
    for n in rec.networks:
        r, h = n.report, n.holdout
        rank = f"{r.rank}th of {r.units}" if r.method == "empirical" else "Gumbel tail fit"
        row = [n.network, str(n.runs), f"{r.threshold:.4g} ({rank})", f"{r.false_alarms}/{r.units} "
               f"[{100 * r.fa_ci[0]:.1f}–{100 * r.fa_ci[1]:.1f} %]", f"{100 * r.expected_fa:.2f} %"]
        if h is None:
            row += ["not checked", "", ""]
        else:
            row += [f"{h.false_alarms}/{h.units} [{100 * h.ci[0]:.1f}–{100 * h.ci[1]:.1f} %]",
                    f"{h.predicted[0]}–{h.predicted[1]}", "yes" if h.inside else "**no**"]
            s.claims.append(Claim(f"calibration-holdout-{n.network}",
                                  f"{n.network}: held-out false alarms inside the calibration's 95 % prediction "
                                  f"interval ({h.units} runs)", h.inside,
                                  f"{h.false_alarms} false alarms, predicted {h.predicted[0]}–{h.predicted[1]}"))
        body.append(row)
    s.lines += table(["network", "calibration runs", "threshold", "in-sample FA", "expected FA (fresh run)",
                      "held-out FA [95 % CI]", "predicted held-out FA", "inside"], body)
    s.lines += ["", *claims_lines(s.claims), ""]
    fig = plot(rec, fig_dir / f"calibration-{plan}.png")
    s.lines += [f"![calibration-{plan}]({fig.relative_to(doc_dir).as_posix()})", ""]
    return s

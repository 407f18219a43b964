"""``report.md``: the summary tables of a run or a campaign, with links to its figures.

A run's table comes from its ``summary.json`` when one sits next to the MCAP file (the numbers
``navbank run`` printed), otherwise from :func:`ground.report.run_facts.run_facts` on the
messages. Missing entries are shown as "–", never an error: a summary from an older or partial
run still renders. Hierarchical gating networks get a table of their mean bank weights before and
after the first fault onset, computed from the messages (a summary does not carry them).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ground.report import campaign_data as C
from ground.report.nav_data import bplane_final, nis_statistics
from ground.report.run_data import DAY_S, RunData, hierarchy_means

REPORT_FILE = "report.md"
DASH = "–"


def _num(v: Any, fmt: str = ".3g") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return DASH
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float)):
        return format(v, fmt)
    return str(v)


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    def esc(x: Any) -> str:
        return str(x).replace("|", "\\|")

    out = ["| " + " | ".join(esc(h) for h in header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(esc(c) for c in row) + " |" for row in rows]
    return out


def _figures(paths: Sequence[Path], out_dir: Path, captions: dict[str, str]) -> list[str]:
    lines: list[str] = []
    for p in paths:
        rel = Path(os.path.relpath(Path(p).resolve(), out_dir.resolve()))
        stem = Path(p).stem
        caption = next((c for prefix, c in captions.items() if stem.startswith(prefix)), stem)
        lines += [f"### {caption}: `{stem}`", "", f"![{stem}]({rel.as_posix()})", ""]
    return lines


RUN_CAPTIONS = {
    "weights_": "Gating-network weights",
    "residuals_": "Pre-fit residuals with ±3σ",
    "residual_histograms": "Normalised residuals against N(0, 1)",
    "bplane_history": "B-plane targeting errors",
    "bplane": "B-plane",
    "hierarchy_": "Hierarchical gating: bank and in-bank weights",
    "position_error_all": "Position error, all filters",
    "position_error_": "Position error vs RTPC",
    "clock_phase_": "Clock phase error",
    "anomaly_statistic": "Anomaly detector",
    "budget": "CPU budget",
    "measurements": "Measurement timeline",
}

CAMPAIGN_CAPTIONS = {
    "mean_weights_after_onset": "Mean weights after onset",
    "mean_weights": "Mean weights (Lubey & Ely 2022 Tables 3/4)",
    "confusion_matrix": "Diagnosis",
    "detection_latency": "Detection latency",
    "detection_probability": "Detection probability",
}


def _hierarchy_lines(data: RunData) -> list[str]:
    """Mean top-level (and in-bank) weights of each hierarchical network before / after the first fault onset."""
    lines: list[str] = []
    onset = data.onset_s
    for net, h in data.hierarchy.items():
        mean = hierarchy_means(h, onset)
        n = mean["updates"]
        origin = {"given": "the run's configuration", "inferred": "inferred from the weights",
                  "unknown": "unknown (no configuration and the weights do not fix them)"}[h.groups_from]
        lines += [f"## Hierarchical gating '{net}': mean bank weights", ""]
        if onset is None:
            lines += [f"No fault injected: means over all {n['all']} weight updates. Banks: {origin}.", ""]
            spans = ["all"]
            header = ["bank", "filters", "mean bank weight g_i", "mean in-bank weights"]
        else:
            day = (onset - data.t0) / DAY_S
            lines += [f"Means over the {n['before']} weight updates before the first fault onset (day {day:.2f}) "
                      f"and the {n['after']} from it on. Banks: {origin}.", ""]
            spans = ["before", "after"]
            header = ["bank", "filters", "g_i before onset", "g_i after onset", "in-bank weights before onset",
                      "in-bank weights after onset"]
        rows = []
        for b in h.banks:
            members = h.members.get(b)
            row = [b, ", ".join(members) if members else DASH]
            row += [_num(mean[f"top_{k}"][b], ".3f") for k in spans]
            row += [", ".join(f"{f} {_num(w, '.2f')}" for f, w in mean[f"in_bank_{k}"][b].items()) if b in h.in_bank else DASH
                    for k in spans]
            rows.append(row)
        lines += _table(header, rows) + [""]
    return lines


def _rqp_lines(data: RunData) -> list[str]:
    """Each RQP adaptation of the best filter (Chaer et al. 1997 §IV): α and J before and after."""
    if not data.rqp:
        return []
    cost = sum(r.cost for r in data.rqp)
    unit = "work units" if data.budget is not None and data.budget.mode == "work-units" else "s of (scaled) CPU"
    lines = ["## RQP parameter adaptation", "",
             f"{len(data.rqp)} adaptations, {sum(r.applied for r in data.rqp)} applied; they were charged {cost:.3g} {unit} "
             "of the frame budget in all. "
             "J is the negative log-likelihood of the window (eq. 22).", ""]
    rows = [[_num(data.day(r.t_s), ".2f"), r.filter,
             ", ".join(f"{p} {_num(a, '.3g')} → {_num(b, '.3g')}" for p, a, b in zip(r.params, r.alpha_before, r.alpha_after)),
             _num(r.nll_before, ".2f"), _num(r.nll_after, ".2f"), _num(r.iterations, "d"), "yes" if r.applied else "no"]
            for r in data.rqp[:50]]
    lines += _table(["day", "filter", "α before → after", "J before", "J after", "iterations", "applied"], rows) + [""]
    if len(data.rqp) > 50:
        lines += [f"(the first 50 of {len(data.rqp)})", ""]
    return lines


def _navigation_lines(data: RunData) -> list[str]:
    """B-plane targeting at the last epoch and NIS statistics per kind and filter."""
    lines: list[str] = []
    final = bplane_final(data.bplane)
    if final:
        lines += ["## B-plane targeting (Mars mean equator)", ""]
        rows = [[label, _num(f["b_dot_r_km"], ".1f"), _num(f["b_dot_t_km"], ".1f"), _num(f["b_dot_r_sigma_km"], ".2f"),
                 _num(f["b_dot_t_sigma_km"], ".2f"), _num(f["b_dot_r_error_km"], "+.2f"), _num(f["b_dot_t_error_km"], "+.2f"),
                 _num(f["periapsis_error_s"], "+.1f"), _num(f["periapsis_sigma_s"], ".1f")] for label, f in final.items()]
        lines += _table(["solution", "B·R [km]", "B·T [km]", "σ B·R [km]", "σ B·T [km]", "B·R error [km]", "B·T error [km]",
                         "closest-approach error [s]", "σ [s]"], rows)
        last = max(f["t_s"] for f in final.values())
        lines += ["", f"At the last B-plane epoch (day {_num(data.day(last), '.2f')}); errors against the truth's B-plane "
                  "at the same epoch; T̂ = Ŝ×k̂/|Ŝ×k̂| with k̂ the Mars pole, R̂ = Ŝ×T̂. Entry-interface time is not "
                  "computed; the closest-approach epoch is on the osculating hyperbola.", ""]
    nis = nis_statistics(data.residuals)
    if nis:
        lines += ["## Normalised innovation squared (NIS)", ""]
        rows = [[kind, name, _num(v["count"], ".0f"), _num(v["dimension"], ".0f"), _num(v["mean_nis"], ".3g"),
                 _num(100 * v["outside_95"], ".1f") + " %"]
                for kind, per in nis.items() for name, v in per.items()]
        lines += _table(["kind", "filter", "processed", "expected mean (n)", "mean NIS", "outside 95 % χ² bounds"], rows)
        lines += ["", "Pre-fit residuals of the measurements each filter processed; a consistent filter has mean "
                  "NIS ≈ n and about 5 % outside the two-sided 95 % bounds of χ²(n).", ""]
    return lines


def run_markdown(facts: dict, figures: Sequence[Path], out_dir: Path, *, source: str, facts_from: str,
                 data: RunData | None = None) -> str:
    """Markdown text of a run report; ``data`` (the extracted messages) adds the hierarchical gating tables."""
    s = facts
    run_id = s.get("run_id")
    lines = [f"# navbank run report: {run_id or source}", ""]
    fault = s.get("fault") or {}
    starts = [e for e in fault.get("events", []) if e.get("event") == "start"]
    rows: list[list[str]] = [
        ["run", _num(run_id)],
        ["recording", source],
        ["scenario", _num(s.get("scenario"))],
        ["seed", _num(s.get("seed"))],
        ["fault case", _num(fault.get("preset") or fault.get("class"))],
    ]
    for ev in starts:
        mag = ", ".join(f"{k} {v:g}" for k, v in (ev.get("magnitude") or {}).items())
        rows.append(["injected", f"{ev.get('type')} ({mag}) on day {_num(ev.get('day'), '.2f')}"])
    mc = s.get("measurements") or {}
    rows.append(["measurements", f"{_num(mc.get('published'), 'd')} published, {_num(mc.get('processed'), 'd')} processed, "
                                 f"{_num(mc.get('rejected'), 'd')} rejected, {_num(mc.get('lost'), 'd')} lost"])
    a = s.get("anomaly") or {}
    if a.get("declared"):
        verdict = ("FALSE ALARM (before any injected fault)" if a.get("false_alarm") else
                   ("diagnosis correct" if a.get("correct_class") else f"diagnosis WRONG (injected {a.get('true_class')})"))
        lat = a.get("latency_s")
        lat_txt = f", {lat / 3600.0:.1f} h after the true onset" if lat is not None else ""
        rows.append(["anomaly", f"declared on day {_num(a.get('time_day'), '.2f')} by {a.get('network')}: {a.get('class')} "
                                f"(confidence {_num(a.get('confidence'), '.2f')}){lat_txt}; {verdict}"])
    elif a.get("onset_true") is not None:
        rows.append(["anomaly", f"none declared: MISSED the injected {a.get('true_class')} fault"])
    else:
        rows.append(["anomaly", "none declared (none injected)"])
    b = s.get("budget") or {}
    if b:
        rows.append(["budget", f"{b.get('mode')}: max utilisation {_num(b.get('max_utilisation'), '.2f')}, "
                               f"{_num(b.get('overruns'), 'd')} overruns, max backlog {_num(b.get('max_backlog'), 'd')}, "
                               f"final backlog {_num(b.get('final_backlog'), 'd')}"])
    lines += _table(["item", "value"], rows) + ["", f"Numbers from {facts_from}.", ""]

    gating = s.get("gating") or {}
    if gating:
        filters = list(s.get("filters") or [])
        for g in gating.values():
            filters += [f for f in g.get("mean_weights", {}) if f not in filters]
        lines += ["## Mean filter weights", ""]
        wrows = []
        for net, g in gating.items():
            for key, label in (("mean_weights", "full arc"), ("mean_weights_before_onset", "before onset"),
                               ("mean_weights_after_onset", "after onset"), ("final_weights", "final")):
                if key in g:
                    wrows.append([net, label] + [_num(g[key].get(f), ".3f") for f in filters])
        lines += _table(["network", "span"] + filters, wrows) + [""]
    if data is not None:
        lines += _hierarchy_lines(data)
        lines += _rqp_lines(data)
        lines += _navigation_lines(data)
    pos = s.get("position_error_rms_km") or {}
    if pos:
        fin = s.get("position_error_final_km") or {}
        w3 = s.get("position_within_3sigma") or {}
        lines += ["## Position error", ""]
        lines += _table(["solution", "RMS [km]", "final [km]", "epochs within 3σ"],
                        [[k, _num(v, ".3g"), _num(fin.get(k), ".3g"), _num(None if w3.get(k) is None else 100 * w3[k], ".0f") + " %"]
                         for k, v in pos.items()]) + [""]
        if "combined" in pos or "best" in pos:
            lines += ["*combined*: the gating-weighted sum of the enabled filters' estimates (Chaer et al. 1997 eq. 3, "
                      "weights of the detector's network); *best*: the filter navigated on — the one with the smallest "
                      "position uncertainty (RTPC) until an anomaly is declared, then the one with the highest weight. "
                      "Within 3σ: the position error is at most 3 RTPC.", ""]
    if figures:
        lines += ["## Figures", ""] + _figures(figures, out_dir, RUN_CAPTIONS)
    return "\n".join(lines).rstrip() + "\n"


def campaign_markdown(camp: C.Campaign, figures: Sequence[Path], out_dir: Path) -> str:
    """Markdown text of a campaign report."""
    rows = camp.rows
    lines = [f"# navbank campaign report: {camp.path.name}", ""]
    uncal = sum(not C.calibrated(r) for r in rows)
    lines += [f"{len(rows)} successful runs, {len(camp.failed)} failed"
              + (f", {camp.bad_lines} unreadable lines in {C.RUNS_FILE}" if camp.bad_lines else "")
              + f"; {len(C.cases(rows))} fault cases; networks: {', '.join(C.networks(rows)) or DASH}."
              + (f" {uncal} runs had no calibrated detector: they count for the weights only." if uncal else ""), ""]
    stats = C.case_stats(rows)
    if stats:
        lines += ["## Detection per fault case", ""]
        trows = []
        for st in stats:
            lo, hi = st.interval
            rate = f"{_num(st.rate, '.2f')} [{_num(lo, '.2f')}, {_num(hi, '.2f')}]"
            lat = sorted(st.latencies_h)
            trows.append([st.label, st.true_class, st.n,
                          rate if st.faulted else DASH,
                          f"{st.false_alarms}/{st.n}",
                          f"{st.correct_class}/{st.detections}" if st.faulted else DASH,
                          _num(lat[len(lat) // 2], ".1f") if lat else DASH])
        lines += _table(["case", "injected class", "runs", "P(detect) [95 % CI]", "false alarms", "correct class / detected",
                         "median latency [h]"], trows)
        lines += ["", "P(detect): declared at or after the true onset. A declaration before the onset is a false alarm, "
                      "even in a faulted run. Intervals: exact (Clopper–Pearson), 95 %.", ""]
    for var in C.variants(rows):
        for net in C.networks(rows):
            mw = C.mean_weights(rows, net, var)
            if mw is None:
                continue
            title = f"## Mean '{net}' weights over the full arc" + (f" (variant {var})" if len(C.variants(rows)) > 1 and var else "")
            lines += [title, ""]
            lines += _table(["case", "runs"] + mw.filters,
                            [[c, int(mw.n[i])] + [_num(mw.mean[i, f], ".4f") for f in range(len(mw.filters))]
                             for i, c in enumerate(mw.cases)]) + [""]
    lines += _campaign_nis_lines(rows)
    if camp.failed:
        lines += ["## Failed runs", ""]
        lines += _table(["id", "cell", "status", "error"],
                        [[r.get("id", DASH), " / ".join(C.cell_parts(r).values()), r.get("status", DASH),
                          _error_text(r.get("error"))] for r in camp.failed[:50]]) + [""]
    if figures:
        lines += ["## Figures", ""] + _figures(figures, out_dir, CAMPAIGN_CAPTIONS)
    return "\n".join(lines).rstrip() + "\n"


def _campaign_nis_lines(rows: list[dict]) -> list[str]:
    """NIS per measurement kind and filter over the campaign's runs that sent residuals: the mean
    NIS of all processed measurements (runs weighted by their counts), its spread over runs, and
    the fraction outside the 95 % chi-square bounds."""
    acc: dict[tuple[str, str], list[tuple[float, float, float, float]]] = {}
    for r in rows:
        for kind, per in ((r.get("summary") or {}).get("nis") or {}).items():
            for name, v in per.items():
                try:
                    acc.setdefault((kind, name), []).append(
                        (float(v["count"]), float(v["dimension"]), float(v["mean_nis"]), float(v["outside_95"])))
                except (KeyError, TypeError, ValueError):
                    continue
    if not acc:
        return []
    trows = []
    for (kind, name), vals in sorted(acc.items()):
        counts = [c for c, _, _, _ in vals]
        total = sum(counts)
        if total <= 0:
            continue
        mean = sum(c * m_ for c, _, m_, _ in vals) / total
        outside = sum(c * o for c, _, _, o in vals) / total
        per_run = sorted(m_ for _, _, m_, _ in vals)
        trows.append([kind, name, len(vals), _num(total, ".0f"), _num(vals[0][1], ".0f"), _num(mean, ".3g"),
                      f"{_num(per_run[0], '.3g')} – {_num(per_run[-1], '.3g')}", _num(100 * outside, ".1f") + " %"])
    lines = ["## Normalised innovation squared (NIS)", ""]
    lines += _table(["kind", "filter", "runs", "processed", "expected mean (n)", "mean NIS", "run means (min – max)",
                     "outside 95 % χ² bounds"], trows)
    return lines + ["", "Pre-fit residuals of the measurements each filter processed, in the runs whose scenario sends "
                        "residual telemetry (`fsw.telemetry.residuals_every_s`).", ""]


def _error_text(err: Any) -> str:
    """A failed run's error in one short line (an error record ``{type, message}`` or text)."""
    if isinstance(err, dict):
        err = f"{err.get('type', '')}: {err.get('message', '')}".strip(": ")
    return " ".join(str(err or "").split())[:120]


def write_markdown(text: str, out_dir: str | Path) -> Path:
    path = Path(out_dir) / REPORT_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path

"""``report.md``: the campaign statistics (``stats.compute``) as Markdown tables."""

from __future__ import annotations

from tools.campaign.stats_records import Binomial, CampaignStats, CellStats, FailedRun, Spread

NOMINAL = "none"


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100.0 * x:.1f} %"


def _ci(ci: tuple[float, ...] | None, scale: float = 100.0, fmt: str = "{:.1f}") -> str:
    if ci is None:
        return ""
    return f" [{fmt.format(scale * ci[0])}, {fmt.format(scale * ci[1])}]"


def _num(x: float | None, fmt: str = "{:.3g}") -> str:
    return "n/a" if x is None else fmt.format(x)


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out + [""]


def _spread(s: Spread | None) -> str:
    return "n/a" if not s else f"{s.mean:.3g} / {s.median:.3g} / {s.max:.3g}"


def _binom(b: Binomial | None) -> str:
    if not b or b.n == 0:
        return "n/a"
    return f"{b.k}/{b.n} = {_pct(b.rate)}{_ci(b.ci)}"


def _short_binom(b: Binomial | None) -> str:
    if not b or b.n == 0:
        return "n/a"
    return f"{b.k}/{b.n} {_pct(b.rate)}{_ci(b.ci, 100.0, '{:.0f}')}"


def _side_by_side(cells: tuple[CellStats, ...]) -> list[str]:
    """Per scenario and variant with several detectors (monitors): one table, fault cases down,
    detectors across, so the networks read side by side."""
    groups: dict[tuple[str, str], list[CellStats]] = {}
    for c in cells:
        if c.base_variant is not None:
            groups.setdefault((c.scenario, c.base_variant), []).append(c)
    lines: list[str] = []
    for (scenario, variant), group in groups.items():
        nets: list[str] = []
        for c in group:
            label = c.variant.removeprefix(f"{variant} / ")
            if label not in nets:
                nets.append(label)
        faults: list[str] = []
        for c in group:
            if c.fault not in faults:
                faults.append(c.fault)
        by = {(c.fault, c.variant.removeprefix(f"{variant} / ")): c for c in group}
        lines += [f"### {scenario} / {variant}: {', '.join(nets)}", "",
                  "P_D for faulted cases, false alarms per run for the nominal case (k/n, rate, "
                  "95 % interval); then latency median / p90 [h] and the correct-class rate among detections.", ""]

        def cell_text(fault: str, net: str) -> str:
            c = by.get((fault, net))
            if c is None:
                return "—"
            if c.nominal:
                fa = c.false_alarm
                per_day = fa.per_day if fa else None
                day = "" if per_day is None or per_day.per_day is None else f"; {per_day.per_day:.3g}/day"
                return "FA " + _short_binom(fa.per_run if fa else None) + day
            return _short_binom(c.detection)

        def lat_text(fault: str, net: str) -> str:
            c = by.get((fault, net))
            lat = c.latency if c is not None else None
            if not lat:
                return "—"
            return f"{lat.median_h:.1f} / {lat.p90_h:.1f}"

        def cls_text(fault: str, net: str) -> str:
            c = by.get((fault, net))
            return "—" if c is None or c.nominal else _short_binom(c.characterization)

        lines += _table(["fault", *nets], [[f, *[cell_text(f, n) for n in nets]] for f in faults])
        # a detector without a cell for the fault counts as faulted: its column then reads "—"
        faulted = [f for f in faults if any(by.get((f, n)) is None or not by[(f, n)].nominal for n in nets)]
        if faulted:
            lines += ["latency median / p90 [h]:", ""]
            lines += _table(["fault", *nets], [[f, *[lat_text(f, n) for n in nets]] for f in faulted])
            lines += ["correct class among detections:", ""]
            lines += _table(["fault", *nets], [[f, *[cls_text(f, n) for n in nets]] for f in faulted])
    return lines


def render(s: CampaignStats) -> str:
    level = int(round(100 * s.confidence_level))
    runs = s.runs
    lines = [f"# Campaign {s.campaign or ''}".rstrip(), ""]
    if s.description:
        lines += [s.description, ""]
    planned = "" if runs.planned is None else f" of {runs.planned} planned"
    lines += [f"Runs: {runs.ok} ok, {runs.failed} failed{planned}"
              + ("" if not runs.missing else f", {runs.missing} not run yet")
              + f"; total run time {runs.wall_time_s_total / 60:.1f} min. "
              f"Intervals are {level} % (Clopper–Pearson for proportions, exact Poisson for rates).", ""]

    lines += ["## Detection", ""]
    hdr = ["scenario", "fault", "variant", "detector", "runs", "P_D", "false alarms / run", "false alarms / day",
           "latency median [h]", "latency p90 [h]", "correct class"]
    rows = []
    for c in s.cells:
        dname = c.detector.network or "?"
        if not c.detector.can_declare:
            dname += " (uncalibrated)"
        fa = c.false_alarm
        per_day = fa.per_day if fa else None
        lat = c.latency
        cell_runs = c.runs
        assert cell_runs is not None  # compute gives every cell its run counts
        rows.append([
            c.scenario, c.fault, c.variant, dname,
            f"{cell_runs.ok}" + (f" (+{cell_runs.failed} failed)" if cell_runs.failed else ""),
            "—" if c.nominal else _binom(c.detection),
            _binom(fa.per_run if fa else None),
            "—" if per_day is None or per_day.per_day is None else
            f"{per_day.per_day:.3g}{_ci(per_day.ci, 1.0, '{:.3g}')}",
            _num(lat.median_h if lat else None, "{:.1f}"), _num(lat.p90_h if lat else None, "{:.1f}"),
            "—" if c.nominal else _binom(c.characterization),
        ])
    lines += _table(hdr, rows)

    side = _side_by_side(s.cells)
    if side:
        lines += ["## Detectors side by side (one set of runs, several networks)", "", *side]

    if s.confusion:
        lines += ["## Characterization (rows: injected class, columns: diagnosed class)", ""]
        for g in s.confusion:
            lines += [f"**{g.scenario} / {g.variant}** (detector {g.detector})", ""]
            lines += _table(["injected \\ diagnosed", *g.diagnosed_classes],
                            [[t, *[str(g.matrix[t][d]) for d in g.diagnosed_classes]] for t in g.true_classes])

    if s.weight_tables:
        lines += ["## Mean gating weights (full arc; Lubey & Ely 2022 Tables 3 and 4 layout)", ""]
        for t in s.weight_tables:
            f = t.filters
            lines += [f"**{t.network}** — {t.scenario} / {t.variant}", ""]
            body = [["Ideal", *[f"{1.0 / len(f):.4f}"] * len(f)]]
            body += [[r.case, *[_num((r.mean or {}).get(x), "{:.4f}") for x in f]] for r in t.rows]
            lines += _table(["case", *f], body)
            after = [(r.case, r.after_onset) for r in t.rows if r.after_onset]
            if after:
                lines += [f"after the fault onset ({t.network}):", ""]
                lines += _table(["case", *f], [[case, *[_num(weights.get(x), "{:.4f}") for x in f]]
                                               for case, weights in after])

    lines += ["## Position error RMS [km] (mean / median / max over seeds)", ""]
    labels: list[str] = []
    for c in s.cells:
        labels += [x for x in c.position_error_rms_km if x not in labels]
    rows = []
    real_cells = [c for c in s.cells if not c.monitor]  # a monitor cell repeats its runs
    for c in real_cells:
        pe = c.position_error_rms_km
        rows.append([c.key, *[_spread(pe.get(x)) for x in labels]])
    lines += _table(["cell", *labels], rows)

    lines += ["## Budget and run time", ""]
    rows = []
    for c in real_cells:
        b = c.budget
        assert b is not None  # compute gives every cell its budget
        w = c.wall_time_s
        rows.append([c.key, _num(b.max_utilisation, "{:.3f}"), str(b.overruns_total),
                     str(b.runs_with_overruns), _num(b.final_backlog_max, "{:.0f}"),
                     _num(w.mean if w else None, "{:.1f}"), _num(w.max if w else None, "{:.1f}")])
    lines += _table(["cell", "max utilisation", "overruns", "runs with overruns", "max final backlog",
                     "wall time mean [s]", "wall time max [s]"], rows)

    failures: list[tuple[str, FailedRun]] = []
    seen_failed: set[str] = set()
    for c in s.cells:  # a failed run appears once, under its first detector
        for run in c.failed:
            if run.id not in seen_failed:
                failures.append((c.key, run))
            seen_failed.add(run.id)
    if failures:
        lines += ["## Failed runs", ""]
        lines += _table(["cell", "seed", "id", "error"],
                        [[k, str(run.seed), run.id, f"{run.type}: {run.message}".replace("|", "\\|")]
                         for k, run in failures])
    uncal: dict[str, int] = {}
    for c in s.cells:
        if c.note:
            net = c.detector.network or "?"
            uncal[net] = uncal.get(net, 0) + 1
    notes = [f"- detector network {net!r} is not calibrated in {n} cell(s): it cannot declare, so detection "
             "and false-alarm statistics are n/a (calibrate it with `navbank calibrate`)" for net, n in uncal.items()]
    if notes:
        lines += ["## Notes", "", *notes, ""]
    return "\n".join(lines).rstrip() + "\n"

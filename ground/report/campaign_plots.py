"""Figures of a fault-injection campaign (a directory with ``runs.jsonl``).

* ``mean_weights_<network>[_<variant>].png`` — mean gating weight per filter per fault case as
  grouped bars, the layout of Lubey & Ely 2022 Tables 3/4; small/medium/large cases of one fault family
  share a group (lighter → darker), error bars are the run-to-run spread;
  ``mean_weights_after_onset_…`` the same over the faulted part of each run only;
* ``confusion_matrix.png`` — injected vs diagnosed anomaly class, counts annotated (campaigns
  with one detector);
* ``networks_compared.png`` — campaigns with several detectors (network variants, or monitors:
  several networks' detectors on the same runs): detection probability per fault case as grouped
  bars with 95 % exact intervals (nominal case: false-alarm rate), and one confusion matrix per
  detector in a row of panels;
* ``weights_vs_time_<network>_<scenario>[_<variant>].png`` — for every network whose weight
  histories the campaign kept (``keep_weights``): weights vs day since scenario start, one panel
  per fault case, per filter the median over seeds with a 10–90 % band, the true fault onset
  marked (the analogue of Lubey & Ely 2022 Figs. 10, 11, 15, 16); nothing when no history was kept;
* ``detection_latency.png`` — latency histogram per faulted case;
* ``detection_probability.png`` — detection probability per case with 95 % exact (Clopper–Pearson) intervals
  (nominal cases: the false-alarm rate).

Each ``plot_*`` writes its PNG and returns the path, or returns the Figure when given no path.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ground.report import campaign_data as C
from ground.report import figure as F

if TYPE_CHECKING:  # matplotlib is imported only when a figure is drawn
    from matplotlib.artist import Artist

_SIZE_ALPHA = {None: 1.0, "small": 0.35, "medium": 0.65, "large": 1.0}


def plot_mean_weights(mw: C.MeanWeights, path: Path | None = None, *, after_onset: bool = False, show_variant: bool = False) -> Any:
    """Grouped bars: one group per fault family, one bar per filter (and size) within it."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    families: list[str] = []
    members: dict[str, list[tuple[int, str | None]]] = {}
    for i, case in enumerate(mw.cases):
        fam, size = C.split_size(case)
        if fam not in members:
            families.append(fam)
            members[fam] = []
        members[fam].append((i, size))
    styles = F.filter_styles(mw.filters)
    nf = len(mw.filters)
    slots_per_group = max(nf * len(m) for m in members.values())
    bar = 0.84 / slots_per_group
    fig, ax = F.new_figure(size=(10.0, 4.4))
    sizes_seen: list[str] = []
    for g, fam in enumerate(families):
        cols = [(f, i, size) for f in range(nf) for i, size in members[fam]]
        for k, (f, i, size) in enumerate(cols):
            x = g + (k - (len(cols) - 1) / 2.0) * bar
            err = mw.std[i, f] if mw.n[i] > 1 else None
            ax.bar(x, mw.mean[i, f], width=bar * 0.92, color=styles[mw.filters[f]]["color"], alpha=_SIZE_ALPHA[size],
                   hatch="//" if styles[mw.filters[f]]["linestyle"] == "--" else None, edgecolor="black", linewidth=0.4,
                   yerr=err, error_kw={"elinewidth": 0.8, "capsize": 2, "ecolor": "black"})
            if size is not None and size not in sizes_seen:
                sizes_seen.append(size)
    ax.axhline(1.0 / nf, color="gray", linestyle=":", linewidth=1.0)
    def tick(fam: str) -> str:
        n = ", ".join(f"{mw.n[i]}" for i, _ in members[fam])
        plural = "s" if sum(mw.n[i] for i, _ in members[fam]) > 1 else ""
        # nominal runs have no onset, so their full-arc mean stands in (campaign_data.mean_weights)
        arc = ", full arc" if after_onset and fam == "none" else ""
        return f"{fam}\n({n} run{plural}{arc})"

    ax.set_xticks(range(len(families)), [tick(fam) for fam in families])
    ax.set_ylim(0.0, 1.05)
    ax.set_ylabel("mean filter weight [-]")
    ax.set_xlabel("fault case")
    ax.grid(True, axis="y", alpha=0.3)
    arc = "after the fault onset" if after_onset else "over the full arc"
    var = f", variant '{mw.variant}'" if mw.variant and show_variant else ""
    ax.set_title(f"Mean '{mw.network}' weights per filter {arc}{var}")
    handles: list[Artist] = [Patch(facecolor=styles[f]["color"], edgecolor="black", linewidth=0.4,
                     hatch="//" if styles[f]["linestyle"] == "--" else None, label=f) for f in mw.filters]
    handles += [Patch(facecolor="dimgray", alpha=_SIZE_ALPHA[s], label=f"{s} fault") for s in C.SIZES if s in sizes_seen]
    handles.append(Line2D([], [], color="gray", linestyle=":", label=f"equal weight 1/{nf}"))
    if (mw.n > 1).any():
        handles.append(Line2D([], [], color="black", marker="|", linestyle="none", markersize=10, label="±1 std over runs"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=9)
    return F.finish(fig, path)


def plot_confusion(classes: tuple[str, ...], mat: np.ndarray, path: Path | None = None) -> Any:
    """Heat map of injected (rows) vs diagnosed (columns) class; colour is the row fraction."""
    rows = [i for i in range(len(classes)) if mat[i].sum() > 0]
    M = mat[rows]
    frac = M / np.maximum(M.sum(axis=1, keepdims=True), 1)
    fig, ax = F.new_figure(size=(8.0, 1.6 + 0.75 * len(rows)))
    im = ax.imshow(frac, cmap="Blues", vmin=0.0, vmax=1.0, aspect="auto")
    for r in range(M.shape[0]):
        for c in range(M.shape[1]):
            ax.text(c, r, f"{M[r, c]}", ha="center", va="center", fontsize=11,
                    color="white" if frac[r, c] > 0.6 else "black")
    ax.set_xticks(range(len(classes)), [c.replace("-", "-\n", 1) for c in classes], fontsize=9)
    ax.set_yticks(range(len(rows)), [f"{classes[i]} ({mat[i].sum()})" for i in rows], fontsize=9)
    ax.set_xlabel("diagnosed class (onboard)")
    ax.set_ylabel("injected class (runs)")
    total = int(mat.sum())
    correct = int(sum(mat[i, i] for i in range(len(classes))))
    ax.set_title(f"Diagnosis confusion matrix: {correct} of {total} runs on the diagonal")
    cb = fig.colorbar(im, ax=ax, fraction=0.04, pad=0.02)
    cb.set_label("fraction of injected class")
    return F.finish(fig, path)


def plot_latency(stats: list[C.CaseStats], path: Path | None = None) -> Any:
    """Detection-latency histograms, one panel per faulted case, common bins."""
    faulted = [s for s in stats if s.faulted]
    if not faulted:
        return None
    all_lat = np.array([x for s in faulted for x in s.latencies_h], dtype=float)
    hi = float(all_lat.max()) if len(all_lat) else 1.0
    bins = np.linspace(0.0, hi * 1.05 if hi > 0 else 1.0, 16)
    ncols = min(3, len(faulted))
    nrows = math.ceil(len(faulted) / ncols)
    fig, axes = F.new_figure(nrows, ncols, size=(10.0, 0.9 + 2.3 * nrows), sharex=True)
    axes = np.atleast_1d(axes).ravel()
    for ax, s in zip(axes, faulted):
        title = f"{s.label}: {s.detections}/{s.n} detected"
        if s.latencies_h:
            ax.hist(s.latencies_h, bins=bins, color="tab:blue", edgecolor="black", linewidth=0.5)
            med = float(np.median(s.latencies_h))
            ax.axvline(med, color="tab:red", linestyle="--", linewidth=1.2)
            title += f", median {med:.1f} h"
        else:
            ax.text(0.5, 0.5, "no detection", transform=ax.transAxes, ha="center", va="center", color="dimgray")
        ax.set_title(title, fontsize=9)
        ax.yaxis.get_major_locator().set_params(integer=True)
        ax.grid(True, alpha=0.3)
    for ax in axes[len(faulted):]:
        ax.set_visible(False)
    for ax in axes[:len(faulted)]:
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel("runs")
        if ax.get_subplotspec().is_last_row() or not axes[min(len(faulted) - 1, len(axes) - 1)].get_visible():
            ax.set_xlabel("latency after true onset [h]")
    fig.suptitle("Detection latency per fault case (declaration epoch − true onset; dashed: median)")
    return F.finish(fig, path)


def plot_detection_probability(stats: list[C.CaseStats], path: Path | None = None) -> Any:
    """Detection probability per case (false-alarm rate for nominal cases), 95 % exact (Clopper–Pearson) intervals."""
    if not stats:
        return None
    fig, ax = F.new_figure(size=(10.0, 4.4))
    x = np.arange(len(stats))
    for i, s in enumerate(stats):
        lo, hi = s.interval
        color = "tab:blue" if s.faulted else "tab:red"
        ax.errorbar(i, s.rate, yerr=[[s.rate - lo], [hi - s.rate]], fmt="o", color=color, capsize=5, markersize=7, elinewidth=1.5)
        k = s.detections if s.faulted else s.false_alarms
        ax.annotate(f"{k}/{s.n}", (i, hi), textcoords="offset points", xytext=(0, 5), ha="center", fontsize=9)
    ax.set_xticks(x, [s.label for s in stats], rotation=25, ha="right", fontsize=9)
    ax.set_xlim(-0.6, len(stats) - 0.4)
    ax.set_ylim(-0.03, 1.12)
    ax.set_ylabel("probability [-]")
    ax.grid(True, axis="y", alpha=0.3)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color="tab:blue", marker="o", linestyle="none", label="detection probability (faulted)"),
               Line2D([], [], color="tab:red", marker="o", linestyle="none", label="false-alarm rate (nominal)"),
               Line2D([], [], color="black", marker="|", markersize=10, linestyle="none", label="95 % Clopper–Pearson interval")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=9)
    ax.set_title("Detection probability per fault case (runs detected / runs)")
    return F.finish(fig, path)


def _confusion_panel(ax: Any, classes: tuple[str, ...], mat: np.ndarray, rows: list[int], cols: list[int],
                     title: str, ylabels: bool) -> Any:
    M = mat[np.ix_(rows, cols)]
    frac = M / np.maximum(M.sum(axis=1, keepdims=True), 1)
    im = ax.imshow(frac, cmap="Blues", vmin=0.0, vmax=1.0, aspect="auto")
    for r in range(M.shape[0]):
        for c in range(M.shape[1]):
            ax.text(c, r, f"{M[r, c]}", ha="center", va="center", fontsize=9,
                    color="white" if frac[r, c] > 0.6 else "black")
    ax.set_xticks(range(len(cols)), [classes[j].replace("-", "-\n", 1) for j in cols], fontsize=7)
    ax.set_yticks(range(len(rows)), [classes[i].replace("-", "-\n", 1) for i in rows] if ylabels else [], fontsize=7)
    correct = int(sum(M[r, c] for r, i in enumerate(rows) for c, j in enumerate(cols) if i == j))
    ax.set_title(f"{title}\n{correct} of {int(M.sum())} on the diagonal", fontsize=9)
    ax.set_xlabel("diagnosed", fontsize=8)
    return im


def plot_detectors_compared(stats: list[C.CaseStats], confusions: dict[str, tuple[tuple[str, ...], np.ndarray]],
                            path: Path | None = None) -> Any:
    """Detectors side by side: P_D per fault case (grouped bars, one per detector, 95 % exact
    intervals; the nominal case shows the false-alarm rate, hatched) above one confusion matrix
    per detector (row fractions as colour, counts annotated)."""
    dets = list(confusions)
    if len(dets) < 2 or not stats:
        return None
    bases = {s.base_variant for s in stats}
    names = {d: (d.split(" / ", 1)[1] if len(bases) == 1 and " / " in d else d) for d in dets}
    case_list = C.reading_order(s.case for s in stats)
    by = {(s.case, s.variant): s for s in stats}
    n = len(dets)
    Figure, Canvas = F.figure_class()
    fig = Figure(figsize=(min(11.5, max(10.0, 3.6 * n)), 8.2), dpi=F.DPI, layout="constrained")
    Canvas(fig)
    mosaic = [["bars"] * n, [f"cm{i}" for i in range(n)]]
    axd = fig.subplot_mosaic(mosaic, height_ratios=[1.1, 1.0])
    ax = axd["bars"]
    from matplotlib.patches import Patch

    width = 0.8 / n
    handles: list[Any] = []
    for k, d in enumerate(dets):
        color = F.PALETTE[k % len(F.PALETTE)]
        handles.append(Patch(facecolor=color, edgecolor="black", linewidth=0.4, label=names[d]))
        for i, case in enumerate(case_list):
            s = by.get((case, d))
            if s is None or s.n == 0:
                continue
            x = i + (k - (n - 1) / 2.0) * width
            lo, hi = s.interval
            ax.bar(x, s.rate, width=width * 0.9, color=color, edgecolor="black", linewidth=0.4,
                   hatch=None if s.faulted else "//")
            ax.errorbar(x, s.rate, yerr=[[s.rate - lo], [hi - s.rate]], fmt="none", ecolor="black", capsize=2, elinewidth=0.8)
    ax.set_xticks(range(len(case_list)), [c if c != "none" else "none (FA rate)" for c in case_list],
                  rotation=25, ha="right", fontsize=8)
    ax.set_xlim(-0.6, len(case_list) - 0.4)
    ax.set_ylim(0.0, 1.08)
    ax.set_ylabel("P(detect) [-]")
    ax.grid(True, axis="y", alpha=0.3)
    handles.append(Patch(facecolor="white", edgecolor="black", linewidth=0.4, hatch="//",
                         label="false-alarm rate (nominal)"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8,
              title="detector", title_fontsize=8)
    ax.set_title("Detection probability per fault case and detector (95 % Clopper–Pearson; hatched: false-alarm rate)",
                 fontsize=10)
    classes_all: list[str] = []
    for classes, _ in confusions.values():
        classes_all += [c for c in classes if c not in classes_all]
    full = {}
    for d, (classes, mat) in confusions.items():
        idx = [classes.index(c) if c in classes else None for c in classes_all]
        M = np.zeros((len(classes_all), len(classes_all)), dtype=int)
        for a, ia in enumerate(idx):
            for b, ib in enumerate(idx):
                if ia is not None and ib is not None:
                    M[a, b] = mat[ia, ib]
        full[d] = M
    rows = [i for i in range(len(classes_all)) if any(M[i].sum() > 0 for M in full.values())]
    cols = [j for j in range(len(classes_all)) if any(M[:, j].sum() > 0 for M in full.values()) or j in rows]
    im = None
    for i, d in enumerate(dets):
        im = _confusion_panel(axd[f"cm{i}"], tuple(classes_all), full[d], rows, cols, names[d], ylabels=i == 0)
    axd["cm0"].set_ylabel("injected", fontsize=8)
    if im is not None:
        cb = fig.colorbar(im, ax=[axd[f"cm{i}"] for i in range(n)], fraction=0.03, pad=0.01)
        cb.set_label("fraction of injected class", fontsize=8)
    return F.finish(fig, path)


def plot_weight_history(wh: C.WeightHistory, path: Path | None = None, *, show_variant: bool = False) -> Any:
    """Weights vs day, one panel per fault case: per filter the median over seeds (line) and the
    10–90 % band over seeds (shaded); dashed red: the true fault onset."""
    nc = len(wh.cases)
    ncols = 1 if nc == 1 else (2 if nc <= 4 else 3)
    nrows = math.ceil(nc / ncols)
    fig, axes = F.new_figure(nrows, ncols, size=(10.0, 1.2 + 2.2 * nrows) if nc > 1 else (10.0, 4.2),
                             sharex=True, sharey=True)
    axes = np.atleast_1d(axes).ravel()
    styles = F.filter_styles(wh.filters)
    for ax, (ci, case) in zip(axes, enumerate(wh.cases)):
        for fi, f in enumerate(wh.filters):
            st = styles[f]
            ax.fill_between(wh.days, wh.p10[ci, :, fi], wh.p90[ci, :, fi], color=st["color"], alpha=0.18, linewidth=0)
            ax.plot(wh.days, wh.median[ci, :, fi], color=st["color"], linestyle=st["linestyle"], linewidth=1.3)
        if np.isfinite(wh.onset_day[ci]):
            ax.axvline(wh.onset_day[ci], color="tab:red", linestyle="--", linewidth=1.0)
        ax.axhline(1.0 / len(wh.filters), color="gray", linestyle=":", linewidth=0.8)
        ax.set_title(f"{case} ({wh.n[ci]} run{'s' if wh.n[ci] != 1 else ''})", fontsize=9)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(True, alpha=0.3)
    for ax in axes[nc:]:
        ax.set_visible(False)
    for i, ax in enumerate(axes[:nc]):
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel("weight [-]")
        if i + ncols >= nc:  # the lowest panel of its column
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel(f"day since {wh.origin}")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Artist] = [Line2D([], [], color=styles[f]["color"], linestyle=styles[f]["linestyle"], label=f)
                             for f in wh.filters]
    handles.append(Patch(facecolor="gray", alpha=0.25, label="10–90 % over seeds"))
    if np.isfinite(wh.onset_day).any():
        handles.append(Line2D([], [], color="tab:red", linestyle="--", label="true fault onset"))
    fig.legend(handles=handles, loc="outside lower center", fontsize=8, ncol=len(handles))
    var = f", variant '{wh.variant}'" if wh.variant and show_variant else ""
    fig.suptitle(f"'{wh.network}' weights vs time, {wh.scenario}{var}: median over seeds, 10–90 % band")
    return F.finish(fig, path)


def write_campaign_figures(campaign: C.Campaign | str | Path, out_dir: str | Path) -> list[Path]:
    """Write every campaign figure into ``out_dir``; returns the paths written."""
    camp = campaign if isinstance(campaign, C.Campaign) else C.load_campaign(campaign)
    out = Path(out_dir)
    rows = camp.rows
    written: list[Path] = []
    if not rows:
        return written
    multi_variant = len(C.variants(rows)) > 1
    for var in C.variants(rows):
        for net in C.networks(rows):
            suffix = F.slug(net) + (f"_{F.slug(var)}" if multi_variant and var else "")
            for which, stem, after in (("mean_weights", "mean_weights", False),
                                       ("mean_weights_after_onset", "mean_weights_after_onset", True)):
                mw = C.mean_weights(rows, net, var, which)
                if mw is None:
                    continue
                if after and not any(C.is_faulted(r) for r in rows if C.variant_of(r) == var):
                    continue
                written.append(plot_mean_weights(mw, out / f"{stem}_{suffix}.png", after_onset=after,
                                                 show_variant=multi_variant))
    for net in C.kept_networks(camp):
        for scen in C.scenarios(rows):
            for var in C.variants(rows):
                wh = C.weight_history(camp, net, scen, var)
                if wh is None:
                    continue
                name = f"weights_vs_time_{F.slug(net)}_{F.slug(scen)}" + (f"_{F.slug(var)}" if multi_variant and var else "")
                written.append(plot_weight_history(wh, out / f"{name}.png", show_variant=multi_variant))
    stats = C.case_stats(rows)
    dvars = C.detector_variants(rows)
    if len(dvars) > 1:
        p = plot_detectors_compared(stats, {v: C.confusion(rows, v) for v in dvars}, out / "networks_compared.png")
        if p is not None:
            written.append(p)
    else:
        classes, mat = C.confusion(rows)
        if mat.sum() > 0:  # nothing to score when no run had a calibrated detector
            written.append(plot_confusion(classes, mat, out / "confusion_matrix.png"))
    for fn, name in ((plot_latency, "detection_latency.png"), (plot_detection_probability, "detection_probability.png")):
        p = fn(stats, out / name)
        if p is not None:
            written.append(p)
    return written

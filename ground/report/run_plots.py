"""Figures of one run, in the form of Lubey & Ely's (2022) results figures.

* ``weights_<network>.png`` — gating-network weights vs time, one line per filter (Figs. 6, 7,
  10, 11, 15, 16, 20–22), fault onset and anomaly declaration marked;
* ``hierarchy_<network>.png`` — hierarchical networks (Chaer et al. 1998 Figs. 5–9): the top-level bank
  weights g_i, then one panel per bank with its in-bank weights g_j|i, events marked alike;
* ``position_error_<filter>.png`` — |estimate − truth| with the ±1σ / 3σ RTPC envelope on a log
  axis (Figs. 3–5, 8, 9, 12, 13, 17–19); ``position_error_all.png`` overlays every filter;
* ``clock_phase_<filter>.png`` — clock phase error with its 1σ / 3σ bounds (Fig. 14);
* ``anomaly_statistic.png`` — the detector's statistic against its threshold, flag shaded;
* ``budget.png`` — frame utilisation and backlog of the executive;
* ``measurements.png`` — which measurement kinds arrived when, coloured by station/target;
* residual and B-plane figures: see :mod:`ground.report.nav_plots`.

Every figure is ~10×4 in at 120 dpi (the hierarchy figure ~2 in per panel) with days since the start of the run on the x axis. Each
``plot_*`` writes its PNG and returns the path, or returns the Figure when given no path.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ground.report import figure as F
from ground.report.nav_plots import write_nav_figures
from ground.report.run_data import RunData, declared_epoch, extract

#: Below this many points a trace is drawn with markers too (batch networks update rarely).
FEW_POINTS = 60
#: Beyond this many declarations the vertical lines share one legend entry.
MAX_LABELLED_DECLARATIONS = 3


#: Colour of the anomaly-declaration lines (the combined solution is black, faults crimson).
DECLARATION_COLOR = "darkviolet"


def _event_lines(ax: Any, data: RunData, *, estimated_onset: bool = True) -> None:
    """Vertical lines: true fault onset/end, anomaly declaration and its estimated onset."""
    seen: set[str] = set()

    def vline(t_s: float, label: str, **kw: Any) -> None:
        ax.axvline(data.day(t_s), label=None if label in seen else label, linewidth=1.4, **kw)
        seen.add(label)

    for ev in data.faults:
        verb = "onset" if ev.event == "start" else "end"
        vline(ev.t_s, f"fault {verb} day {data.day(ev.t_s):.2f} ({ev.fault_type})", color="crimson",
              linestyle="--" if ev.event == "start" else ":")
    if data.anomaly is not None:
        decl = data.anomaly.declarations
        many = len(decl) > MAX_LABELLED_DECLARATIONS  # a flapping flag: one legend entry, not dozens
        for r in decl:
            t = declared_epoch(r)
            label = (f"anomaly declared ({len(decl)} times)" if many
                     else f"anomaly declared day {data.day(t):.2f}: {r.anomaly_class}")
            # not black: the combined solution is drawn solid black on the same axes
            vline(t, label, color=DECLARATION_COLOR, linestyle="-")
            if estimated_onset and r.onset_s is not None:
                vline(r.onset_s, "estimated onset" if many else f"estimated onset day {data.day(r.onset_s):.2f}",
                      color="dimgray", linestyle="-.")


def _time_axis(ax: Any, data: RunData) -> None:
    ax.set_xlabel("time since start of run [days]")
    ax.grid(True, which="major", alpha=0.3)


def plot_weights(data: RunData, network: str, path: Path | None = None) -> Any:
    """Weights of ``network`` vs time on a linear 0–1 axis; steps, since weights hold between updates."""
    trace = data.weights[network]
    fig, ax = F.new_figure()
    styles = F.filter_styles(trace.filters)
    days = data.day(trace.t_s)
    few = len(days) <= FEW_POINTS
    for i, name in enumerate(trace.filters):
        ax.plot(days, trace.weights[:, i], drawstyle="steps-post", linewidth=1.6, label=name,
                marker="o" if few else None, markersize=3.5, **styles[name])
    n = len(trace.filters)
    if n:
        ax.axhline(1.0 / n, color="gray", linewidth=0.8, linestyle=":", label=f"equal weight 1/{n}")
    _event_lines(ax, data)
    ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel("filter weight [-]")
    _time_axis(ax, data)
    ax.set_title(f"Gating network '{network}': filter weights ({len(days)} updates)")
    F.legend_outside(ax)
    return F.finish(fig, path)


def plot_hierarchy(data: RunData, network: str, path: Path | None = None) -> Any:
    """Top-level bank weights g_i, then the in-bank weights g_j|i of each bank (Chaer et al. 1998 Figs. 5–9);
    only the top level when the bank membership is unknown."""
    h = data.hierarchy[network]
    banks = [b for b in h.banks if b in h.in_bank]
    fig, axes = F.new_figure(1 + len(banks), 1, size=(10.0, 1.0 + 2.0 * (1 + len(banks))), sharex=True)
    axes = np.atleast_1d(axes)
    days = data.day(h.t_s)
    few = len(days) <= FEW_POINTS
    marker = {"marker": "o" if few else None, "markersize": 3.5}
    bank_styles = F.filter_styles(h.banks)
    for i, b in enumerate(h.banks):
        axes[0].plot(days, h.top[:, i], drawstyle="steps-post", linewidth=1.6, label=b, **marker, **bank_styles[b])
    known = {"given": "", "inferred": ", banks inferred from the weights", "unknown": ", bank membership unknown"}
    axes[0].set_title(f"Hierarchical gating network '{network}': top-level bank weights g_i "
                      f"({len(days)} updates{known[h.groups_from]})", loc="left")
    for ax, b in zip(axes[1:], banks):
        styles = F.filter_styles(h.members[b])
        for j, f in enumerate(h.members[b]):
            ax.plot(days, h.in_bank[b][:, j], drawstyle="steps-post", linewidth=1.4, label=f, **marker, **styles[f])
        ax.set_title(f"bank '{b}': in-bank weights g_j|i = w_j / g_i", loc="left", fontsize=10)
    for k, ax in enumerate(axes):
        handles, labels = ax.get_legend_handles_labels()
        _event_lines(ax, data, estimated_onset=False)
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("weight [-]")
        ax.grid(True, which="major", alpha=0.3)
        if k == 0:
            F.legend_outside(ax)
        else:  # the event lines are explained once, in the top panel's legend
            F.legend_outside(ax, handles=handles, labels=labels)
    _time_axis(axes[-1], data)
    return F.finish(fig, path)


def plot_position_error(data: RunData, label: str, path: Path | None = None) -> Any:
    """Position error magnitude with the ±1σ / 3σ RTPC envelope, log axis (Lubey & Ely 2022 Figs. 3–5)."""
    tr = data.position[label]
    fig, ax = F.new_figure()
    days = data.day(tr.t_s)
    ax.semilogy(days, _positive(tr.error), color=F.ERROR_COLOR, linewidth=1.5, label="position error |r̂ − r|")
    ax.semilogy(days, tr.sigma, color=F.SIGMA1_COLOR, linewidth=1.3, label="1σ RTPC")
    ax.semilogy(days, 3.0 * tr.sigma, color=F.SIGMA3_COLOR, linewidth=1.3, label="3σ RTPC")
    _event_lines(ax, data)
    ax.set_ylabel("position [km]")
    _time_axis(ax, data)
    ax.grid(True, which="minor", alpha=0.12)
    inside = float(np.mean(tr.error <= 3.0 * tr.sigma)) if len(tr.error) else float("nan")
    ax.set_title(f"Position error vs RTPC — {_estimate_name(label)}: {100 * inside:.0f} % of epochs within 3σ")
    F.legend_outside(ax)
    return F.finish(fig, path)


def plot_position_errors_all(data: RunData, path: Path | None = None) -> Any:
    """Every estimate stream's position error on one log axis (which filter is best when)."""
    labels = [lb for lb in _ordered_estimates(data) if len(data.position[lb].t_s)]
    styles = F.filter_styles([lb for lb in labels if lb not in ("combined", "best")])
    styles["combined"] = {"color": "black", "linestyle": "-"}
    styles["best"] = {"color": "black", "linestyle": ":"}
    fig, ax = F.new_figure()
    for lb in labels:
        tr = data.position[lb]
        ax.semilogy(data.day(tr.t_s), _positive(tr.error), linewidth=1.4, label=lb, **styles[lb])
    _event_lines(ax, data, estimated_onset=False)
    ax.set_ylabel("position error [km]")
    _time_axis(ax, data)
    ax.grid(True, which="minor", alpha=0.12)
    ax.set_title("Position error of every filter and of the combined / best solutions")
    F.legend_outside(ax)
    return F.finish(fig, path)


def plot_clock_phase(data: RunData, label: str, path: Path | None = None) -> Any:
    """Estimated minus true clock phase with its 1σ / 3σ bounds, in microseconds (Lubey & Ely 2022 Fig. 14)."""
    tr = data.clock[label]
    fig, ax = F.new_figure()
    days = data.day(tr.t_s)
    us = 1.0e6
    ax.plot(days, tr.error * us, color=F.ERROR_COLOR, linewidth=1.5, label="clock phase error (estimate − truth)")
    for k, color in ((1.0, F.SIGMA1_COLOR), (3.0, F.SIGMA3_COLOR)):
        ax.plot(days, k * tr.sigma * us, color=color, linewidth=1.2, label=f"±{k:g}σ")
        ax.plot(days, -k * tr.sigma * us, color=color, linewidth=1.2)
    ax.axhline(0.0, color="gray", linewidth=0.6)
    _event_lines(ax, data)
    ax.set_ylabel("clock phase [µs]")
    _time_axis(ax, data)
    ax.set_title(f"Clock phase error and uncertainty — {_estimate_name(label)}")
    F.legend_outside(ax)
    return F.finish(fig, path)


def plot_anomaly_statistic(data: RunData, path: Path | None = None) -> Any:
    """Detection statistic vs its threshold, periods with the flag raised shaded."""
    an = data.anomaly
    assert an is not None
    fig, ax = F.new_figure()
    days = data.day(an.t_s)
    ax.plot(days, an.statistic, drawstyle="steps-post", color="tab:blue", linewidth=1.5, marker="o", markersize=3,
            label="detection statistic D")
    ax.plot(days, an.threshold, drawstyle="steps-post", color="darkorange", linestyle="-", linewidth=1.6,
            label="declaration threshold")
    for k, (start, end) in enumerate(_runs(an.flag)):
        t_end = days[end] if end < len(days) else max(days[-1], _last_day(data))
        ax.axvspan(days[start], t_end, color="gold", alpha=0.25, linewidth=0, label="flag raised" if k == 0 else None)
    _event_lines(ax, data)
    top = np.nanmax(np.concatenate([an.statistic, an.threshold])) if len(days) else 1.0
    if np.isfinite(top) and top > 0 and np.nanmax(an.threshold, initial=0.0) > 0 and top / np.nanmax(an.threshold) > 20:
        ax.set_yscale("symlog", linthresh=max(float(np.nanmax(an.threshold)), 1e-3))
    ax.set_ylim(bottom=0.0)  # D is non-negative: no room below zero
    ax.set_ylabel("statistic D [-]")
    _time_axis(ax, data)
    net = f" on '{an.network}' weights" if an.network else ""
    n = len(an.declarations)
    ax.set_title(f"Anomaly detector{net}: statistic vs threshold, {n} declaration{'' if n == 1 else 's'}")
    F.legend_outside(ax)
    return F.finish(fig, path)


def plot_budget(data: RunData, path: Path | None = None) -> Any:
    """Utilisation per frame and backlog depth of the frame executive."""
    b = data.budget
    assert b is not None
    fig, (ax1, ax2) = F.new_figure(2, 1, size=(10.0, 5.0), sharex=True)
    days = data.day(b.t_s)
    busy = b.processed > 0
    # utilisation spans decades (idle frames ~0, busy frames up to overruns > 1): log axis
    util = np.where(b.utilisation > 0, b.utilisation, np.nan)
    ms = 2.5 if len(days) > FEW_POINTS * 10 else 6.0
    ax1.semilogy(days[~busy], util[~busy], linestyle="none", marker=".", markersize=ms, color="silver", label="idle frames")
    ax1.semilogy(days[busy], util[busy], linestyle="none", marker=".", markersize=ms, color="tab:blue", label="frames with work")
    ax1.axhline(1.0, color="tab:red", linestyle="--", linewidth=1.2, label="budget (100 %)")
    ax1.set_ylabel("utilisation\n[used / budget]")
    finite = util[np.isfinite(util)]
    low = float(np.percentile(finite, 1)) if len(finite) else 1e-3
    ax1.set_ylim(bottom=max(low * 0.5, 1e-6), top=max(2.0, float(np.nanmax(util, initial=0.0)) * 1.5))
    ax1.grid(True, alpha=0.3)
    unit = "scaled CPU s" if b.mode == "cpu" else "work units"
    ax1.set_title(f"Frame executive ({b.mode} budget, {unit}): {len(days)} frame reports, {b.overruns} overruns, "
                  f"{b.errors} errors, max backlog {int(b.backlog.max(initial=0))}")
    F.legend_outside(ax1, markerscale=8.0 / ms)
    ax2.plot(days, b.backlog, drawstyle="steps-post", color="tab:purple", linewidth=1.4, label="backlog (jobs)")
    ax2.plot(days, b.deferred, drawstyle="steps-post", color="tab:olive", linewidth=1.0, alpha=0.8, label="stages deferred")
    ax2.set_ylabel("count [-]")
    peak = int(max(b.backlog.max(initial=0), b.deferred.max(initial=0)))
    ax2.set_ylim(bottom=0.0, top=max(peak, 1) * 1.1)  # counts: nothing below zero
    ax2.yaxis.get_major_locator().set_params(integer=True)
    if peak == 0:
        ax2.text(0.5, 0.5, "no backlog and no deferred stages during the run", transform=ax2.transAxes,
                 ha="center", va="center", fontsize=10, color="dimgray")
    _time_axis(ax2, data)
    F.legend_outside(ax2)
    return F.finish(fig, path)


def plot_measurements(data: RunData, path: Path | None = None) -> Any:
    """Measurement timeline: one row per kind, one tick per measurement; within a row each station
    or target has its own lane and colour, so interleaved sources do not hide one another."""
    from matplotlib.lines import Line2D

    kinds = list(data.measurements)
    fig, ax = F.new_figure(size=(10.0, max(2.6, 1.2 + 0.9 * len(kinds))))
    sources = sorted({s for _, src in data.measurements.values() for s in src})
    colors = {s: F.PALETTE[i % len(F.PALETTE)] for i, s in enumerate(sources)}
    for row, kind in enumerate(kinds):
        t, src = data.measurements[kind]
        lanes = sorted(set(src))
        height = 0.8 / len(lanes)
        for k, s in enumerate(lanes):
            sel = src == s
            y = row + ((len(lanes) - 1) / 2.0 - k) * height  # alphabetical top-down, like the legend
            ax.plot(data.day(t[sel]), np.full(int(sel.sum()), y), linestyle="none", marker="|",
                    markersize=max(3.0, 40.0 * height), markeredgewidth=0.8, color=colors[s])
    ax.set_yticks(range(len(kinds)), [f"{k}\n({len(data.measurements[k][0])})" for k in kinds])
    ax.set_ylim(-0.6, len(kinds) - 0.4)
    _event_lines(ax, data, estimated_onset=False)
    handles, labels = ax.get_legend_handles_labels()
    proxies = [Line2D([], [], linestyle="none", marker="s", markersize=7, color=colors[s]) for s in sources]
    _time_axis(ax, data)
    ax.grid(False, axis="y")
    ax.set_ylabel("measurement kind\n(count)")
    total = sum(len(t) for t, _ in data.measurements.values())
    ax.set_title(f"Measurement timeline: {total} measurements by kind and station / target")
    ax.legend(proxies + handles, sources + labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=9)
    return F.finish(fig, path)


def write_run_figures(messages: Iterable[Any] | RunData, out_dir: str | Path, *, t0: float | None = None) -> list[Path]:
    """Write every figure the run's messages allow into ``out_dir``; returns the paths written."""
    data = messages if isinstance(messages, RunData) else extract(messages, t0=t0)
    out = Path(out_dir)
    written: list[Path] = []
    for net in data.weights:
        written.append(plot_weights(data, net, out / f"weights_{F.slug(net)}.png"))
    for net in data.hierarchy:
        written.append(plot_hierarchy(data, net, out / f"hierarchy_{F.slug(net)}.png"))
    for label in _ordered_estimates(data):
        if len(data.position[label].t_s):
            written.append(plot_position_error(data, label, out / f"position_error_{F.slug(label)}.png"))
    if sum(1 for tr in data.position.values() if len(tr.t_s)) > 1:
        written.append(plot_position_errors_all(data, out / "position_error_all.png"))
    for label in _ordered_estimates(data, data.clock):
        if len(data.clock[label].t_s):
            written.append(plot_clock_phase(data, label, out / f"clock_phase_{F.slug(label)}.png"))
    if data.anomaly is not None and len(data.anomaly.t_s):
        written.append(plot_anomaly_statistic(data, out / "anomaly_statistic.png"))
    if data.budget is not None and len(data.budget.t_s):
        written.append(plot_budget(data, out / "budget.png"))
    if data.measurements:
        written.append(plot_measurements(data, out / "measurements.png"))
    written += write_nav_figures(data.residuals, data.bplane, data.t0, out)
    return written


def _ordered_estimates(data: RunData, traces: dict | None = None) -> list[str]:
    """Estimate labels in bank order, then combined and best."""
    traces = data.position if traces is None else traces
    order = [f for f in data.filters if f in traces] + [lb for lb in ("combined", "best") if lb in traces]
    return order + sorted(lb for lb in traces if lb not in order)


def _last_day(data: RunData) -> float:
    """Last epoch with data (days), so a flag still raised at the end is shaded to the end."""
    ends = [float(t[-1]) for t, _ in data.measurements.values() if len(t)]
    return float(data.day(max(ends))) if ends else 0.0


def _estimate_name(label: str) -> str:
    return {"combined": "'combined' (weighted sum)", "best": "'best' (highest-weight filter)"}.get(label, f"filter '{label}'")


def _positive(x: np.ndarray) -> np.ndarray:
    """Zero errors cannot sit on a log axis: show them as gaps, not as a crash or a spike."""
    return np.where(x > 0, x, np.nan)


def _runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """(first, one-past-last) indices of each run of True."""
    runs, start = [], None
    for i, f in enumerate(flag):
        if f and start is None:
            start = i
        elif not f and start is not None:
            runs.append((start, i))
            start = None
    if start is not None:
        runs.append((start, len(flag)))
    return runs

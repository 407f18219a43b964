"""Navigation-quality figures of a run (data from :mod:`ground.report.nav_data`):

* ``residuals_<kind>_<source>.png`` — pre-fit residuals of every filter (one panel each) against
  time with the ±3σ band of the innovation covariance (σ = √S); measurements a filter did not
  process are drawn hollow;
* ``residual_histograms.png`` — normalised residuals of the processed measurements per kind and
  filter against the standard normal density;
* ``bplane.png`` — B·T / B·R at the last B-plane epoch of each estimate with its 1σ and 3σ
  ellipses, and the truth;
* ``bplane_history.png`` — B·R, B·T and closest-approach time errors against truth with ±3σ.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fsw.interface import kinds
from ground.report import figure as F
from ground.report.nav_data import BPlaneTrace, ResidualTrace

DAY_S = 86400.0


def _unit(kind: str) -> str:
    decl = kinds.BY_NAME.get(kind)
    return "" if decl is None else decl.unit


def plot_residuals(tr: ResidualTrace, t0: float, path: Path | None = None) -> Any:
    n_f, n_c = len(tr.filters), tr.residual.shape[2]
    fig, axes = F.new_figure(n_f, 1, size=(10.0, 1.2 + 1.9 * n_f), sharex=True)
    axes = np.atleast_1d(axes)
    days = (tr.t_s - t0) / DAY_S
    styles = F.filter_styles(list(tr.filters))
    markers = ("o", "s", "^", "D")
    for i, (ax, name) in enumerate(zip(axes, tr.filters)):
        color = styles[name]["color"]
        for k in range(n_c):
            sig3 = 3.0 * tr.sigma[:, i, k]
            order = np.argsort(days)
            label3 = "±3σ (√S)" if k == 0 else None
            ax.fill_between(days[order], -sig3[order], sig3[order], color=color, alpha=0.15, linewidth=0, label=label3)
            done = tr.processed[:, i]
            comp = f" [{k}]" if n_c > 1 else ""
            if np.any(done):
                ax.plot(days[done], tr.residual[done, i, k], markers[k % 4], markersize=2.5, color=color,
                        label=f"processed{comp}")
            if np.any(~done):
                ax.plot(days[~done], tr.residual[~done, i, k], markers[k % 4], markersize=3.5, markerfacecolor="none",
                        color=color, alpha=0.6, label=f"not processed{comp}")
        inside = float(np.mean(np.abs(tr.normalised[:, i, :]) <= 3.0)) if len(days) else float("nan")
        ax.set_ylabel(f"{name}\n[{_unit(tr.kind)}]")
        ax.set_title(f"{name}: {100 * inside:.1f} % of residual components within ±3σ", fontsize=9, loc="left")
        ax.grid(True, alpha=0.3)
        F.legend_outside(ax)
    axes[0].figure.suptitle(f"Pre-fit residuals — {tr.kind} from {tr.source} ({len(days)} measurements)")
    axes[-1].set_xlabel("time since start of run [days]")
    return F.finish(fig, path)


def plot_residual_histograms(traces: dict[tuple[str, str], ResidualTrace], path: Path | None = None) -> Any:
    by_kind: dict[str, list[ResidualTrace]] = {}
    for tr in traces.values():
        by_kind.setdefault(tr.kind, []).append(tr)
    kinds_seen = sorted(by_kind)
    filters = next(iter(traces.values())).filters
    fig, axes = F.new_figure(len(kinds_seen), len(filters), size=(3.4 * len(filters), 2.6 * len(kinds_seen)))
    axes = np.atleast_2d(axes).reshape(len(kinds_seen), len(filters))
    x = np.linspace(-5, 5, 201)
    pdf = np.exp(-0.5 * x * x) / np.sqrt(2 * np.pi)
    for r, kind in enumerate(kinds_seen):
        for c, name in enumerate(filters):
            ax = axes[r, c]
            vals = np.concatenate([tr.normalised[tr.processed[:, c], c, :].ravel() for tr in by_kind[kind]])
            if vals.size:
                ax.hist(np.clip(vals, -5, 5), bins=50, range=(-5, 5), density=True, color="tab:blue", alpha=0.6)
                ax.set_title(f"{kind} — {name}\nmean {np.mean(vals):+.2f}, sd {np.std(vals):.2f}, n={vals.size}", fontsize=9)
            else:
                ax.set_title(f"{kind} — {name}\n(not processed)", fontsize=9)
            ax.plot(x, pdf, color="black", linewidth=1.2, label="N(0, 1)")
            ax.set_xlim(-5, 5)
            if r == len(kinds_seen) - 1:
                ax.set_xlabel("normalised residual z/σ")
            ax.grid(True, alpha=0.3)
    axes[0, -1].legend(fontsize=8)
    fig.suptitle("Normalised pre-fit residuals of processed measurements (values beyond ±5 clipped into the end bins)")
    return F.finish(fig, path)


def _ellipse(cov: np.ndarray, n_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (B·T offset, B·R offset) of the n-sigma ellipse of cov over (B·R, B·T)."""
    vals, vecs = np.linalg.eigh(cov)
    a = np.linspace(0, 2 * np.pi, 200)
    pts = vecs @ (n_sigma * np.sqrt(np.maximum(vals, 0.0))[:, None] * np.vstack([np.cos(a), np.sin(a)]))
    return pts[1], pts[0]


def plot_bplane(traces: dict[str, BPlaneTrace], path: Path | None = None) -> Any:
    fig, ax = F.new_figure(size=(8.0, 6.5))
    labels = [lb for lb in traces if len(traces[lb].t_s)]
    styles = F.filter_styles([lb for lb in labels if lb not in ("combined", "best")])
    truth_drawn = False
    for label in labels:
        tr = traces[label]
        color = "black" if label == "combined" else "tab:red" if label == "best" else styles[label]["color"]
        bt, br, cov = tr.b_dot_t[-1], tr.b_dot_r[-1], tr.cov[-1]
        ax.plot([bt], [br], "o", color=color, markersize=9 if label == "best" else 6, zorder=3 if label == "best" else 4,
                label=label)
        for n_sigma, ls in ((1.0, "-"), (3.0, "--")):
            dx, dy = _ellipse(cov, n_sigma)
            ax.plot(bt + dx, br + dy, ls, color=color, linewidth=1.0)
        if not truth_drawn and np.isfinite(tr.true_b_dot_t[-1]):
            ax.plot([tr.true_b_dot_t[-1]], [tr.true_b_dot_r[-1]], "*", color="gold", markersize=14,
                    markeredgecolor="black", label="truth", zorder=5)
            truth_drawn = True
    ax.set_xlabel("B·T [km]")
    ax.set_ylabel("B·R [km]")
    ax.invert_yaxis()  # B·R points south of the Mars equator: the navigator's convention draws it downward
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.set_title("B-plane (Mars mean equator) at the last B-plane epoch\n1σ ellipses solid, 3σ dashed", fontsize=10)
    F.legend_outside(ax)
    return F.finish(fig, path)


def plot_bplane_history(traces: dict[str, BPlaneTrace], t0: float, path: Path | None = None) -> Any:
    labels = [lb for lb in ("combined", "best") if lb in traces and len(traces[lb].t_s)] or list(traces)[:2]
    fig, axes = F.new_figure(3, 1, size=(10.0, 8.0), sharex=True)
    for label, color in zip(labels, ("black", "tab:red")):
        tr = traces[label]
        days = (tr.t_s - t0) / DAY_S
        rows = ((tr.b_dot_r - tr.true_b_dot_r, np.sqrt(np.maximum(tr.cov[:, 0, 0], 0.0)), "B·R error [km]"),
                (tr.b_dot_t - tr.true_b_dot_t, np.sqrt(np.maximum(tr.cov[:, 1, 1], 0.0)), "B·T error [km]"),
                (tr.periapsis_s - tr.true_periapsis_s, tr.periapsis_sigma_s, "closest-approach time error [s]"))
        for ax, (err, sig, ylabel) in zip(axes, rows):
            ax.plot(days, err, "-o", markersize=3, color=color, label=f"{label} error")
            ax.plot(days, 3 * sig, ":", color=color, label=f"{label} ±3σ")
            ax.plot(days, -3 * sig, ":", color=color)
            ax.set_ylabel(ylabel)
            ax.set_yscale("symlog", linthresh=1.0)
            ax.grid(True, alpha=0.3)
    for ax in axes:
        F.legend_outside(ax)
    axes[-1].set_xlabel("time since start of run [days]")
    axes[0].set_title("B-plane targeting errors against truth with the mapped ±3σ")
    return F.finish(fig, path)


def write_nav_figures(residuals: dict[tuple[str, str], ResidualTrace], bplanes: dict[str, BPlaneTrace], t0: float,
                      out: Path) -> list[Path]:
    written: list[Path] = []
    for (kind, source), tr in residuals.items():
        written.append(plot_residuals(tr, t0, out / f"residuals_{F.slug(kind)}_{F.slug(source)}.png"))
    if residuals:
        written.append(plot_residual_histograms(residuals, out / "residual_histograms.png"))
    if any(len(tr.t_s) for tr in bplanes.values()):
        written.append(plot_bplane(bplanes, out / "bplane.png"))
        written.append(plot_bplane_history(bplanes, t0, out / "bplane_history.png"))
    return written

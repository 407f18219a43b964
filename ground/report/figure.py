"""Figures for reports: matplotlib (an optional dependency) loaded on first use, Agg rendering.

Figures are made with :class:`matplotlib.figure.Figure` directly rather than through pyplot, so
nothing touches the user's interactive backend or pyplot's global figure list, and writing a
report from a worker thread is safe.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

#: How a reader without matplotlib gets it.
INSTALL_HINT = "pip install 'navbank[plots]'  (or: pip install matplotlib)"

FIGSIZE = (10.0, 4.0)  # inches
DPI = 120

#: Colours of Lubey & Ely's (2022) error figures: error blue, 1-sigma orange, 3-sigma red.
ERROR_COLOR = "tab:blue"
SIGMA1_COLOR = "tab:orange"
SIGMA3_COLOR = "tab:red"

PALETTE = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan", "tab:gray", "tab:red")
#: Filters that carry inflated process noise (Lubey & Ely 2022 §4.4) share their base filter's colour, dashed.
HIGH_Q_SUFFIX = "-Q"


class PlottingUnavailable(RuntimeError):
    """matplotlib is not installed."""

    def __init__(self) -> None:
        super().__init__(f"plots need matplotlib, which is not installed: {INSTALL_HINT}")


def figure_class() -> Any:
    """matplotlib's Figure and Agg canvas classes (raises :class:`PlottingUnavailable` without matplotlib)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise PlottingUnavailable() from None
    return Figure, FigureCanvasAgg


def new_figure(nrows: int = 1, ncols: int = 1, *, size: tuple[float, float] = FIGSIZE, **subplot_kw: Any) -> tuple[Any, Any]:
    """A constrained-layout figure and its axes (legends placed outside the axes still fit)."""
    Figure, Canvas = figure_class()
    fig = Figure(figsize=size, dpi=DPI, layout="constrained")
    Canvas(fig)  # render with Agg whatever backend pyplot may be using
    axes = fig.subplots(nrows, ncols, squeeze=True, **subplot_kw)
    return fig, axes


def save(fig: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, format="png")
    return path


def finish(fig: Any, path: Path | None) -> Any:
    """Write ``fig`` to ``path`` and return the path; without a path return the figure itself
    (to inspect what was drawn)."""
    return fig if path is None else save(fig, Path(path))


def slug(text: str) -> str:
    """A file-name-safe form of a filter or network name."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "x"


def filter_styles(names: tuple[str, ...] | list[str]) -> dict[str, dict[str, Any]]:
    """Line style of each filter: one colour per base filter, high-Q variants dashed in the same colour."""
    styles: dict[str, dict[str, Any]] = {}
    bases: list[str] = []
    for name in names:
        base = name[: -len(HIGH_Q_SUFFIX)] if name.endswith(HIGH_Q_SUFFIX) else name
        if base not in bases:
            bases.append(base)
    for name in names:
        high_q = name.endswith(HIGH_Q_SUFFIX)
        base = name[: -len(HIGH_Q_SUFFIX)] if high_q else name
        styles[name] = {"color": PALETTE[bases.index(base) % len(PALETTE)], "linestyle": "--" if high_q else "-"}
    return styles


def legend_outside(ax: Any, **kw: Any) -> Any:
    """Legend to the right of the axes, so it never hides data."""
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=9, **kw)

"""Mean-weight tables from a campaign directory's run rows: per scenario, fault case and gating
network, the mean over seeds of each run's mean weight per filter, and its spread over seeds."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from ground.report.row_types import ResultRow
from ground.report.summary_types import RunSummary
from tools.campaign.store import read_rows


@dataclass
class WeightRow:
    case: str
    n: int
    mean: dict[str, float]
    std: dict[str, float]


def ok_rows(campaign_dir: str | Path) -> list[ResultRow]:
    """The latest successful row of every run of a campaign directory."""
    latest = read_rows(Path(campaign_dir) / "runs.jsonl").latest()
    return [r for r in latest.values() if r.ok]


def summary_of(row: ResultRow) -> RunSummary:
    """The summary of a row of :func:`ok_rows` (an ok row always has one)."""
    assert row.summary is not None, f"run {row.id} has no summary: not an ok row"
    return row.summary


def weight_table(rows: list[ResultRow], network: str, *, scenario: str | None = None,
                 which: Literal["mean_weights", "mean_weights_after_onset"] = "mean_weights") -> dict[str, WeightRow]:
    """case -> WeightRow for ``network`` (``which``: mean_weights or mean_weights_after_onset)."""
    acc: dict[str, list[dict[str, float]]] = {}
    for r in rows:
        if scenario is not None and r.cell.scenario != scenario:
            continue
        g = summary_of(r).gating.get(network)
        weights = getattr(g, which) if g is not None else None
        if not weights:
            continue
        acc.setdefault(r.cell.fault, []).append(weights)
    out = {}
    for case, vals in acc.items():
        names = list(vals[0])
        arr = np.array([[v[n] for n in names] for v in vals])
        out[case] = WeightRow(case, len(vals), dict(zip(names, arr.mean(axis=0).tolist())),
                              dict(zip(names, arr.std(axis=0, ddof=1).tolist() if len(vals) > 1 else [0.0] * len(names))))
    return out


def means(table: dict[str, WeightRow]) -> dict[str, dict[str, float]]:
    return {c: r.mean for c, r in table.items()}

"""One benchmark row: what was measured, against what, and whether the goal is met.

Every row holds ``name``, ``ours``, ``reference``, ``unit``, ``ratio``, ``goal`` and ``met``,
plus ``meaning`` (what the ratio is, in one line) and free details. The ratio is always
computed from ``ours`` and ``reference`` by the row's :class:`Goal`: ``reference / ours`` for a
cost (time, CPU per item: higher is better), ``ours / reference`` for a rate or a share, and
``ours / reference − 1`` for the gain of an added worker; the goal is a bound (``>=`` or ``<=``)
on that ratio, or on ``ours`` itself where the goal is absolute (budget overruns, decoded
messages per second).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

#: How the ratio is formed: ``cost`` reference / ours (a time: smaller ours is better), ``rate``
#: ours / reference (a throughput or a share), ``gain`` ours / reference − 1 (what one more worker adds).
RatioKind = Literal["cost", "rate", "gain"]


@dataclass(frozen=True)
class Goal:
    """``<on> op value``, where ``on`` is the ratio (formed as ``kind`` says) or ours itself (a
    count, or an absolute figure such as messages per second)."""

    kind: RatioKind
    op: Literal[">=", "<="]
    value: float
    on: Literal["ratio", "ours"] = "ratio"
    unit: str = ""

    def ratio(self, ours: float, reference: float) -> float:
        num, den = (reference, ours) if self.kind == "cost" else (ours, reference)
        if den == 0:
            return math.inf if num > 0 else math.nan
        return num / den - (1.0 if self.kind == "gain" else 0.0)

    def met(self, ours: float, ratio: float) -> bool:
        x = ratio if self.on == "ratio" else ours
        if math.isnan(x):
            return False
        return x >= self.value if self.op == ">=" else x <= self.value

    def text(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        return f"{self.on} {self.op} {self.value:g}{unit}"


def make_row(name: str, ours: float, reference: float, unit: str, goal: Goal, meaning: str,
             **details: Any) -> dict[str, Any]:
    """A benchmark row (a JSON-ready dict) with its ratio and verdict computed from ``goal``."""
    ratio = goal.ratio(ours, reference)
    met = goal.met(float(ours), ratio)
    # JSON has no inf or NaN: a ratio that is not a number (a zero measurement) is null
    return {"name": name, "ours": float(ours), "reference": float(reference), "unit": unit,
            "ratio": ratio if math.isfinite(ratio) else None, "goal": goal.text(), "met": met, "meaning": meaning,
            **details}


def skipped_row(name: str, unit: str, goal: Goal, reason: str) -> dict[str, Any]:
    """A row that could not be measured in this run (not met; ``skipped`` says why)."""
    return {"name": name, "ours": None, "reference": None, "unit": unit, "ratio": None, "goal": goal.text(),
            "met": False, "meaning": "", "skipped": reason}


def text_line(row: dict[str, Any]) -> str:
    """One human-readable line of a row (and, for a per-measurement cost split by stage, a second
    line with the split)."""
    if row.get("skipped"):
        return f"{row['name']:<28} skipped: {row['skipped']}"
    verdict = "met" if row["met"] else "NOT met"
    ratio = "-" if row["ratio"] is None else f"{row['ratio']:.3g}"
    line = (f"{row['name']:<28} ours {row['ours']:12.4g} {row['unit']:<16} reference {row['reference']:12.4g}"
            f"   ratio {ratio:>8}  goal {row['goal']:<12} {verdict:<8} ({row['meaning']})")
    if "outputs_identical" in row:  # a comparison of two implementations on the same input
        line += f"\n    outputs identical: {'yes' if row['outputs_identical'] else 'NO'}"
        if row.get("per_repeat_ratios"):
            line += "; ratio of each repeat: " + ", ".join(f"{r:.3f}" for r in row["per_repeat_ratios"])
        if row.get("first_difference"):
            line += "\n    " + row["first_difference"]
    stages = row.get("stage_us_per_measurement")
    if stages:
        # where a per-measurement cost goes, stage by stage, is what one acts on
        parts = [f"{label} {us:.1f}" for label, us in sorted(stages.items(), key=lambda kv: -kv[1])]
        if row.get("outside_stages_us_per_measurement") is not None:
            parts.append(f"outside the stages {row['outside_stages_us_per_measurement']:.1f}")
        line += "\n" + " " * 4 + "CPU per measurement by stage (us): " + ", ".join(parts)
    return line


__all__ = ["Goal", "make_row", "skipped_row", "text_line"]

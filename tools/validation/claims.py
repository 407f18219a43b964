"""The qualitative findings of Lubey & Ely 2022 Tables 3 and 4, as checks on navbank's mean weight tables.

Each check returns a :class:`Claim`: the paper's statement, whether navbank's numbers satisfy it,
and the numbers that decide it. The validation report prints them; the slow tests
(tests/test_validation_orderings.py) run reduced campaigns and compare with what the report says.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

Table = Mapping[str, Mapping[str, float]]  # case -> filter -> mean weight

TABLE3_CASES = ("no bias", "small bias - optical", "medium bias - optical", "large bias - optical",
                "small bias - radio", "medium bias - radio", "large bias - radio")


@dataclass(frozen=True)
class Claim:
    key: str
    statement: str
    holds: bool
    evidence: str


def _fmt(row: Mapping[str, float]) -> str:
    return ", ".join(f"{k} {v:.3f}" for k, v in row.items())


def _top(row: Mapping[str, float]) -> str:
    return max(row, key=lambda k: row[k])


def _bottom(row: Mapping[str, float]) -> str:
    return min(row, key=lambda k: row[k])


def table3_claims(chi2: Table, magill: Table | None = None) -> list[Claim]:
    """Lubey & Ely 2022 Table 3 / Figs. 10, 11, 15, 16 orderings (issue thresholds)."""
    out: list[Claim] = []
    nb = chi2["no bias"]
    n = len(nb)
    dev = max(abs(v - 1.0 / n) for v in nb.values())
    out.append(Claim("no-bias", "no bias: chi2 weights within 0.05 of 1/3", dev <= 0.05,
                     f"{_fmt(nb)} (largest deviation {dev:.3f})"))
    row = chi2["small bias - optical"]
    out.append(Claim("small-optical", "small optical bias: radio weight highest", _top(row) == "radio", _fmt(row)))
    for size in ("medium", "large"):
        row = chi2[f"{size} bias - optical"]
        ok = row["radio"] > 0.8 and _bottom(row) == "fused"
        out.append(Claim(f"{size}-optical", f"{size} optical bias: radio > 0.8 and fused lowest", ok, _fmt(row)))
    for size in ("small", "medium"):
        row = chi2[f"{size} bias - radio"]
        dev = max(abs(row[k] - nb[k]) for k in row)
        out.append(Claim(f"{size}-radio", f"{size} radio bias: within 0.03 of the no-bias weights", dev <= 0.03,
                         f"{_fmt(row)} (largest difference {dev:.3f})"))
    row = chi2["large bias - radio"]
    out.append(Claim("large-radio", "large radio bias: optical weight highest", _top(row) == "optical", _fmt(row)))
    if magill is not None:
        not_fused = [c for c in TABLE3_CASES if c in magill and _top(magill[c]) != "fused"]
        ev = "; ".join(f"{c}: {_fmt(magill[c])}" for c in not_fused) or \
            "fused highest in every case (lowest fused mean " + \
            f"{min(magill[c]['fused'] for c in TABLE3_CASES if c in magill):.3f})"
        out.append(Claim("magill-fused", "Magill prefers the fused filter in all seven cases", not not_fused, ev))
    return out


def table4_claim(case: str, row: Mapping[str, float]) -> Claim:
    """Lubey & Ely 2022 Table 4: optical / optical-Q highest, the low-Q radio and fused filters lowest."""
    ranked = sorted(row, key=row.__getitem__)
    ok = _top(row) in ("optical", "optical-Q") and set(ranked[:2]) == {"radio", "fused"}
    return Claim(f"table4-{case}", f"{case}: optical or optical-Q highest, low-Q radio and fused lowest", ok,
                 _fmt(row))

"""A section of the validation document: its Markdown lines, the claims it checks, and the
Markdown pieces every section writes (tables, claim lines, figure links)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from tools.validation.claims import Claim


@dataclass
class Section:
    title: str
    lines: list[str] = field(default_factory=list)
    claims: list[Claim] = field(default_factory=list)
    discussion: str = ""


def _tick(ok: bool) -> str:
    return "reproduces" if ok else "**does not reproduce**"


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    def cell(text: str) -> str:
        return text.replace("|", "\\|")  # "KF 2|2" must not split a cell

    out = ["| " + " | ".join(map(cell, header)) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(map(cell, r)) + " |" for r in rows]
    return out


def claims_lines(claims: list[Claim]) -> list[str]:
    return [f"* {c.statement}: {_tick(c.holds)} — {c.evidence}" for c in claims]


def figure_links(figs: list[Path], doc_dir: Path) -> list[str]:
    return [f"![{f.stem}]({f.relative_to(doc_dir).as_posix()})" for f in figs]

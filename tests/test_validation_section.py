"""Markdown pieces of the validation document's sections."""

from pathlib import Path

from tools.validation.claims import Claim
from tools.validation.section import claims_lines, figure_links, table


def test_table_escapes_pipes_inside_cells():
    assert table(["bank", "weight"], [["KF 2|2", "0.5"]]) == ["| bank | weight |", "|---|---|", "| KF 2\\|2 | 0.5 |"]


def test_claims_and_figures():
    claims = [Claim("a", "radio wins", True, "0.9 > 0.1"), Claim("b", "fused loses", False, "0.4")]
    assert claims_lines(claims) == ["* radio wins: reproduces — 0.9 > 0.1", "* fused loses: **does not reproduce** — 0.4"]
    assert figure_links([Path("/d/figures/w.png")], Path("/d")) == ["![w](figures/w.png)"]

"""The validation report's checks of Lubey & Ely's (2022) orderings: the paper's own tables must pass them,
and tables that break an ordering must fail exactly that check."""

from __future__ import annotations

import pytest

from tools.validation import paper
from tools.validation.claims import table3_claims, table4_claim


def _paper_table3():
    return {case: dict(zip(paper.TABLE3_FILTERS, w)) for case, w in paper.TABLE3_CHI2.items()}


def test_the_papers_table_3_satisfies_every_ordering():
    claims = table3_claims(_paper_table3())
    assert len(claims) == 7 and all(c.holds for c in claims), [c for c in claims if not c.holds]


@pytest.mark.parametrize("case", sorted(paper.TABLE4_CHI2))
def test_the_papers_table_4_satisfies_the_ordering(case):
    assert table4_claim(case, dict(zip(paper.TABLE4_FILTERS, paper.TABLE4_CHI2[case]))).holds


def test_a_broken_ordering_fails_only_its_own_check():
    t = _paper_table3()
    t["medium bias - optical"] = {"radio": 0.465, "optical": 0.465, "fused": 0.070}
    t["small bias - radio"] = {"radio": 0.30, "optical": 0.37, "fused": 0.33}
    failed = {c.key for c in table3_claims(t) if not c.holds}
    assert failed == {"medium-optical", "small-radio"}
    bad = next(c for c in table3_claims(t) if c.key == "small-radio")
    assert "0.043" in bad.evidence  # the largest difference from the no-bias row is reported


def test_magill_check_names_the_cases_where_fused_is_not_preferred():
    magill = {c: {"radio": 0.001, "optical": 0.0, "fused": 0.999} for c in paper.TABLE3_CHI2}
    assert next(c for c in table3_claims(_paper_table3(), magill) if c.key == "magill-fused").holds
    magill["large bias - optical"] = {"radio": 0.001, "optical": 0.998, "fused": 0.001}
    claim = next(c for c in table3_claims(_paper_table3(), magill) if c.key == "magill-fused")
    assert not claim.holds and claim.evidence.startswith("large bias - optical")


def test_table_4_low_q_filters_must_be_the_two_lowest():
    row = dict(zip(paper.TABLE4_FILTERS, (0.10, 0.25, 0.05, 0.08, 0.30, 0.22)))  # radio-Q below radio
    assert not table4_claim("x", row).holds

"""Shared test data: the short scenarios tests fly, and complete campaign rows."""

from __future__ import annotations

import pytest

from campaign_rows import complete_row
from ground.report.row_types import ResultRow


@pytest.fixture
def result_row():
    """``result_row(partial_json) -> ResultRow`` (see :func:`complete_row`)."""
    return lambda partial: ResultRow.from_json(complete_row(partial))


SHORT_E2E = """\
name: short-e2e
description: four-day approach slice with a large optical bias from day 1.5
seed: 2
sim:
  trajectory: {span_days: 4.0}
  faults:
    - {type: optical-bias, onset_day: 1.5, sample_px: 20.0, line_px: 30.0}
fsw:
  gating:
    - {network: chi2, batch_size: 300}
    - {network: magill}
"""


@pytest.fixture(scope="session")
def short_e2e_yaml() -> str:
    """The four-day approach slice the end-to-end tests fly: a large optical bias from day 1.5,
    chi2 and Magill networks (the ``fsw:`` mapping comes last, so a test can append to it)."""
    return SHORT_E2E


def _short_scenario(span_days: float = 2.0, *, gating: tuple[str, ...] = ("{network: chi2, batch_size: 200}",
                                                                          "{network: magill}"),
                    faults: tuple[str, ...] = (), work_units: bool = True, detector: str | None = None) -> str:
    lines = ["name: short", "sim:", f"  trajectory: {{span_days: {span_days}}}"]
    if faults:
        lines += ["  faults:", *(f"    - {f}" for f in faults)]
    lines.append("fsw:")
    if work_units:
        lines.append("  budget: {mode: work-units}")
    lines += ["  gating:", *(f"    - {g}" for g in gating)]
    if detector is not None:
        lines.append(f"  detector: {{network: {detector}}}")
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="session")
def short_scenario():
    """``short_scenario(span_days=2.0, *, gating, faults, work_units=True, detector=None)``: the
    YAML of the short scenario campaign tests expand and fly (``name: short``; by default two days,
    work-unit budget, chi2 with batches of 200 and Magill)."""
    return _short_scenario

"""Shared test data: the short scenarios tests fly, and complete campaign rows."""

from __future__ import annotations

import pytest

from campaign_rows import complete_row
from ground.report.row_types import ResultRow


@pytest.fixture
def result_row():
    """``result_row(partial_json) -> ResultRow`` (see :func:`complete_row`)."""
    return lambda partial: ResultRow.from_json(complete_row(partial))

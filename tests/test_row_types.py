"""A campaign result row reads and writes the ``runs.jsonl`` line campaigns have always written."""

from __future__ import annotations

import json

import pytest

from fsw.interface.typed import DecodeError
from ground.report.row_types import Cell, DetectorFacts, ResultRow

# a failed run's line, as the runner wrote it before the records existed
FAILED = ('{"id":"5e0c","cell":{"scenario":"s","fault":"optical-bias-small","variant":"broken"},"seed":2,'
          '"fault_class":"optical-measurement","detector":{"network":"chi2","calibrated":true,"monitors":["magill"]},'
          '"span_days":4.0,"host":"node1","pid":17,"status":"failed","error":{"type":"TimeError",'
          '"message":"bad epoch 2018-13-45","traceback":"Traceback (most recent call last): ..."},"summary":null,'
          '"wall_time_s":0.5,"finished_utc":"2026-11-24T04:30:00Z","campaign":"c","executor":"dask"}')


def test_failed_row_round_trip():
    row = ResultRow.from_json(json.loads(FAILED))
    assert row.cell == Cell("s", "optical-bias-small", "broken") and row.cell.key == "s / optical-bias-small / broken"
    assert row.detector == DetectorFacts(network="chi2", calibrated=True, monitors=("magill",))
    assert not row.ok and row.error.message == "bad epoch 2018-13-45" and row.executor == "dask"
    assert json.dumps(row.to_json(), separators=(",", ":")) == FAILED


def test_keys_written_only_when_known():
    row = ResultRow(id="x", cell=Cell("s", "none", "v"), seed=1, fault_class="none",
                    detector=DetectorFacts(network="chi2", calibrated=False), span_days=2.0, status="failed")
    assert row.to_json() == {
        "id": "x", "cell": {"scenario": "s", "fault": "none", "variant": "v"}, "seed": 1, "fault_class": "none",
        "detector": {"network": "chi2", "calibrated": False}, "span_days": 2.0, "status": "failed", "error": None,
        "summary": None, "wall_time_s": None, "finished_utc": ""}


def test_a_line_that_is_not_a_row_is_refused():
    data = json.loads(FAILED)
    data["cell"] = "s / optical-bias-small / broken"
    with pytest.raises(DecodeError, match="cell"):
        ResultRow.from_json(data)

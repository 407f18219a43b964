"""plan.json: the record reads and writes the file campaigns have always written."""

from __future__ import annotations

import json

from tools.campaign.plan_file import PlanFile

PLAN_JSON = """{
 "name": "mon",
 "description": "",
 "cells": [
  {
   "scenario": "short",
   "fault": "none",
   "variant": "three",
   "key": "short / none / three",
   "fault_class": "none",
   "detector": {
    "network": "chi2",
    "calibrated": true,
    "monitors": [
     "magill"
    ]
   }
  },
  {
   "scenario": "short",
   "fault": "optical-bias-medium",
   "variant": "three",
   "key": "short / optical-bias-medium / three"
  }
 ],
 "runs": [
  {
   "id": "0f3c2a9b4d5e6f70",
   "cell": "short / none / three",
   "seed": 1
  }
 ]
}"""


def test_plan_json_round_trip():
    plan = PlanFile.from_json(json.loads(PLAN_JSON))
    nominal, faulted = plan.cells
    assert nominal.detector.monitors == ("magill",) and faulted.fault_class is None and faulted.detector is None
    assert plan.runs[0].cell == nominal.key
    assert json.dumps(plan.to_json(), indent=1) == PLAN_JSON

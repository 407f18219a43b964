"""The record ``navbank calibrate --report`` writes: plan, per-network calibration and hold-out check.

``navbank validation-report`` reads it back (``campaigns/calibration-<scenario>.json``) for its
section on the shipped thresholds, so the documented numbers are the calibration's own.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from fsw.interface import typed
from fsw.interface.typed import spec
from tools.calibration.plan import CalibrationPlan
from tools.calibration.thresholds import CalibrationReport, HoldoutCheck


@dataclass(frozen=True)
class NetworkCalibration:
    network: str = spec(doc="Gating network")
    runs: int = spec(doc="Nominal runs the calibration used", ge=0)
    report: CalibrationReport = spec(doc="What the calibration chose, in sample")
    holdout: HoldoutCheck | None = spec(None, doc="The out-of-sample check, when held-out runs were flown")
    holdout_runs: int = spec(0, doc="Held-out runs with this network's weights", ge=0)
    command: str = spec("", doc="The command line that reproduces this calibration")


@dataclass(frozen=True)
class CalibrationRecord:
    plan: CalibrationPlan = spec(doc="The procedure (options resolved)")
    generated: str = spec(doc="UTC date of the calibration")
    networks: tuple[NetworkCalibration, ...] = spec(doc="One entry per calibrated network")


def write_record(record: CalibrationRecord, path: str | Path) -> None:
    Path(path).write_text(json.dumps(typed.encode(record), indent=1) + "\n", encoding="utf-8")


def read_record(path: str | Path) -> CalibrationRecord:
    return typed.decode(CalibrationRecord, json.loads(Path(path).read_text(encoding="utf-8")))

"""The run summary's declared records read and write the JSON ``summary.json`` has always held."""

from __future__ import annotations

import json

import pytest

from fsw.interface.typed import DecodeError
from ground.report.summary_types import AnomalyBlock, GatingEntry, MonitorBlock, RunSummary

# summary.json of a `navbank run` (abridged to one filter), as written before the records existed
RUN_SUMMARY = """{
  "scenario": "insight-approach",
  "seed": 7,
  "t0": 592645689.0,
  "fault": {
    "preset": "optical-bias-medium",
    "class": "optical-measurement",
    "events": [
      {
        "id": "optical-bias",
        "type": "optical-bias",
        "event": "start",
        "t_s": 594373689.0,
        "day": 20.0,
        "magnitude": {
          "line_px": 1.0,
          "sample_px": 1.0
        }
      }
    ]
  },
  "measurements": {
    "published": 28610,
    "processed": 28610,
    "rejected": 0,
    "lost": 0,
    "duplicates": 0,
    "reordered": 0
  },
  "filters": [
    "radio"
  ],
  "gating": {
    "chi2": {
      "mean_weights": {
        "radio": 1.0
      },
      "updates": 28,
      "mean_weights_before_onset": {
        "radio": 1.0
      },
      "mean_weights_after_onset": {
        "radio": 1.0
      },
      "final_weights": {
        "radio": 1.0
      }
    }
  },
  "anomaly": {
    "detector": true,
    "declared": false,
    "time": null,
    "time_day": null,
    "onset_true": 594373689.0,
    "onset_true_day": 20.0,
    "onset_estimate": null,
    "latency_s": null,
    "class": "none",
    "true_class": "optical-measurement",
    "confidence": 0.0,
    "network": "chi2",
    "false_alarm": false,
    "correct_class": null,
    "final_flag": false,
    "final_class": "none"
  },
  "position_error_rms_km": {
    "radio": 2.5
  },
  "position_error_final_km": {
    "radio": 1.5
  },
  "position_within_3sigma": {
    "radio": 0.98
  },
  "budget": {
    "frames": 3888,
    "reports": 3888,
    "overruns": 0,
    "max_utilisation": 0.5,
    "mean_utilisation_busy": 0.25,
    "max_backlog": 1,
    "final_backlog": 0,
    "errors": 0,
    "mode": "work-units"
  },
  "wall_time_s": 31.5,
  "run_id": "20261124-0430-ab12",
  "files": {
    "mcap": "runs/20261124-0430-ab12/run.mcap",
    "config": "runs/20261124-0430-ab12/config.yaml"
  }
}
"""

DETECTION = {
    "detector": True, "declared": True, "time": 2000.0, "time_day": 0.5, "onset_true": 1000.0,
    "onset_true_day": 0.25, "onset_estimate": 1100.0, "latency_s": 1000.0, "class": "optical-measurement",
    "true_class": "optical-measurement", "confidence": 0.75, "network": "magill", "false_alarm": False,
    "correct_class": True, "final_flag": True, "final_class": "optical-measurement", "first_class": "unknown",
    "latency_day": 0.25,
}


def test_run_summary_reads_and_writes_summary_json_byte_for_byte():
    s = RunSummary.from_json(json.loads(RUN_SUMMARY))
    assert s.fault.fault_class == "optical-measurement" and s.fault.events[0].magnitude["line_px"] == 1.0
    assert s.gating["chi2"].updates == 28 and s.anomaly.anomaly_class == "none" and not s.anomaly.detected
    assert s.files.mcap.endswith("run.mcap") and s.monitors is None
    assert json.dumps(s.to_json(), indent=2) + "\n" == RUN_SUMMARY


def test_optional_keys_appear_only_when_set():
    a = AnomalyBlock.from_json(DETECTION)
    assert a.first_class == "unknown" and a.first_diagnosis == "unknown" and a.diagnosed == "optical-measurement"
    assert list(a.to_json()) == list(DETECTION)  # the order summary.json has
    quiet = {k: v for k, v in DETECTION.items() if k not in ("first_class", "latency_day")}
    assert "first_class" not in AnomalyBlock.from_json(quiet).to_json()
    nominal = GatingEntry.from_json({"mean_weights": {"radio": 1.0}, "updates": 3, "final_weights": {"radio": 1.0}})
    assert nominal.to_json() == {"mean_weights": {"radio": 1.0}, "updates": 3, "final_weights": {"radio": 1.0}}


def test_a_monitor_is_an_anomaly_block_or_an_error():
    ok = MonitorBlock._typed_decode(DETECTION, "monitors.magill")
    assert ok.anomaly.network == "magill" and ok.error is None and ok._typed_encode(False) == DETECTION
    err = {"error": {"type": "FdirInputError", "message": "NaN weights", "traceback": "Traceback ..."}}
    bad = MonitorBlock._typed_decode(err, "monitors.magill")
    assert bad.anomaly is None and bad.error.type == "FdirInputError" and bad._typed_encode(False) == err


def test_a_summary_that_does_not_fit_names_the_key():
    data = json.loads(RUN_SUMMARY)
    data["anomaly"]["declared"] = "yes"
    with pytest.raises(DecodeError, match="anomaly.declared"):
        RunSummary.from_json(data)
    del data["anomaly"]
    with pytest.raises(DecodeError, match="anomaly"):
        RunSummary.from_json(data)

"""Complete campaign rows and run summaries (JSON) built from the few fields a test cares about."""

from __future__ import annotations

import copy


ANOMALY_NONE = {
    "detector": True, "declared": False, "time": None, "time_day": None, "onset_true": None,
    "onset_true_day": None, "onset_estimate": None, "latency_s": None, "class": "none", "true_class": "none",
    "confidence": 0.0, "network": "chi2", "false_alarm": False, "correct_class": None, "final_flag": False,
    "final_class": "none",
}
SUMMARY_NOMINAL = {
    "scenario": "s", "seed": 1, "t0": 0.0,
    "fault": {"preset": None, "class": "none", "events": []},
    "measurements": {"published": 0, "processed": 0, "rejected": 0, "lost": 0, "duplicates": 0, "reordered": 0},
    "filters": [], "gating": {}, "anomaly": ANOMALY_NONE,
    "position_error_rms_km": {}, "position_error_final_km": {}, "position_within_3sigma": {},
    "budget": {"frames": 0, "reports": 0, "overruns": 0, "max_utilisation": 0.0, "mean_utilisation_busy": 0.0,
               "max_backlog": 0, "final_backlog": 0, "errors": 0, "mode": "work-units"},
    "wall_time_s": None,
}
ROW_NOMINAL = {
    "id": "r", "cell": {"scenario": "s", "fault": "none", "variant": "v"}, "seed": 1, "fault_class": "none",
    "detector": {"network": "chi2", "calibrated": True}, "span_days": 10.0, "status": "ok", "error": None,
    "summary": None, "wall_time_s": None, "finished_utc": "2026-01-01T00:00:00Z",
}


def _anomaly(partial: dict) -> dict:
    return {**ANOMALY_NONE, **{k: v for k, v in partial.items() if v is not None or k in ANOMALY_NONE}}


def complete_summary(partial: dict) -> dict:
    """A whole summary's JSON: ``partial`` over a nominal one (anomaly, budget, gating entries and
    monitors completed key by key)."""
    out = {**copy.deepcopy(SUMMARY_NOMINAL), **{k: v for k, v in partial.items()
                                                if k not in ("anomaly", "budget", "gating", "monitors")}}
    out["anomaly"] = _anomaly(partial.get("anomaly") or {})
    out["budget"] = {**SUMMARY_NOMINAL["budget"], **(partial.get("budget") or {})}
    out["gating"] = {net: {"updates": 0, "final_weights": g["mean_weights"], **g}
                     for net, g in (partial.get("gating") or {}).items()}
    if partial.get("monitors") is not None:
        out["monitors"] = {net: m if "error" in m else _anomaly(m) for net, m in partial["monitors"].items()}
    return out


def complete_row(partial: dict) -> dict:
    """A whole result row's JSON: ``partial`` over a nominal row, its summary completed."""
    out = {**copy.deepcopy(ROW_NOMINAL), **partial}
    if out.get("summary") is not None:
        out["summary"] = complete_summary(out["summary"])
    return out

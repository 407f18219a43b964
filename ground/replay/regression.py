"""``navbank replay --rerun``: re-fly a recorded run's measurements and diff the FSW telemetry.

A regression check after changing FSW code: in work-unit budget mode the FSW is deterministic,
so an unchanged FSW reproduces every recorded ``/fsw/...`` message exactly (zero difference). A
run recorded in CPU budget mode is re-run in CPU mode: which stage fits in which frame then
depends on measured CPU time, so budget reports are compared by count only, and the combined
and best estimates (which use the latest weights at each estimate epoch) and the status
counters may legitimately differ.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field

from fsw.astro.time import TimeError, tdb_to_utc_iso
from fsw.config import FswConfig
from fsw.interface import codec, topics
from ground.replay.compare import Comparison, compare_runs
from ground.replay.fsw_config import load_fsw_config
from ground.replay.recording import RecordingError, iter_raw, run_info
from ground.replay.rerun import RerunResult, recorded_commands, recorded_measurement_stream, rerun_fsw

BUDGET_TOPIC = topics.mcap_topic(topics.FSW_BUDGET)
FSW_PREFIX = "/fsw/"
CPU_NOTE = ("budget mode cpu: stage timing depends on measured CPU time, so budget reports are compared by count "
            "only, and combined/best estimates and status counters may legitimately differ")


@dataclass
class RegressionResult:
    run_id: str
    config: FswConfig
    changes: list[str]
    rerun: RerunResult
    comparison: Comparison
    undecodable_recorded: int = 0  # recorded /fsw messages that did not decode (compared as raw JSON)
    notes: list[str] = field(default_factory=list)
    recorded_config: str = ""  # the scenario YAML attached to the recording
    recorded_config_name: str = ""

    @property
    def identical(self) -> bool:
        return self.comparison.identical


def recorded_fsw_telemetry(path: str | os.PathLike) -> tuple[dict[str, list], int]:
    """Recorded ``/fsw/...`` messages per MCAP topic, in publication (sequence) order."""
    raw: dict[str, list] = {}
    for msg in iter_raw(path):
        if msg.topic.startswith(FSW_PREFIX):
            raw.setdefault(msg.topic, []).append(msg)
    out: dict[str, list] = {}
    bad = 0
    for topic, msgs in raw.items():
        msgs.sort(key=lambda m: m.sequence)  # stable: log order where sequences are absent (all 0)
        try:
            cls = topics.type_of_topic(topic)
        except KeyError:
            continue
        decoded: list[object] = []
        for m in msgs:
            try:
                decoded.append(codec.from_json(cls, m.data))
            except codec.ICDError:
                bad += 1
                try:
                    decoded.append(json.loads(m.data))
                except ValueError:
                    decoded.append({"_raw": m.data.decode("utf-8", "replace")})
        out[topic] = decoded
    return out, bad


def rerun_and_compare(
    path: str | os.PathLike,
    *,
    overrides: Sequence[str] = (),
    replacement: str | os.PathLike | None = None,
    tolerance: float = 0.0,
    rtol: float = 0.0,
) -> RegressionResult:
    """Re-run the FSW of the recorded run in ``path`` (changed as asked) and compare its outputs:
    a number agrees when |a − b| ≤ ``tolerance`` or |a − b| ≤ ``rtol`` · max(|a|, |b|)."""
    if not (tolerance >= 0.0 and math.isfinite(tolerance)):
        raise ValueError(f"tolerance must be a finite number >= 0, got {tolerance}")
    if not (rtol >= 0.0 and math.isfinite(rtol)):
        raise ValueError(f"rtol must be a finite number >= 0, got {rtol}")
    info = run_info(path)
    if info.config_text is None:
        raise RecordingError(f"{info.path}: no configuration attached (runs recorded by `navbank run` carry config.yaml)")
    label = f"{info.path}:{info.config_name}"
    config = load_fsw_config(info.config_text, label, overrides=overrides,
                             replacement=os.fspath(replacement) if replacement is not None else None)
    as_recorded = load_fsw_config(info.config_text, label) if (overrides or replacement is not None) else config
    stream, _ = recorded_measurement_stream(path)
    if not stream:
        raise RecordingError(f"{info.path}: no /sim/measurements recorded")
    rerun = rerun_fsw(config, stream, run_id=info.run_id or "rerun", commands=recorded_commands(path))
    rerun_topics: dict[str, list] = {}
    for topic, msg in rerun.outputs:
        rerun_topics.setdefault(topics.mcap_topic(topic), []).append(msg)
    recorded, bad = recorded_fsw_telemetry(path)
    counts_only = {}
    notes = []
    if config.budget.mode == "cpu":
        counts_only[BUDGET_TOPIC] = "cpu mode: counts only"
        notes.append(CPU_NOTE)
    if not info.complete:
        notes.append("the recording has no footer (cut short): its last messages are missing, counts will differ")
    notes += calibration_notes(as_recorded, config)
    changes = [f"--config {os.fspath(replacement)}"] if replacement is not None else []
    changes += [f"--set {o}" for o in overrides]
    comparison = compare_runs(recorded, rerun_topics, tolerance=tolerance, rtol=rtol, counts_only=counts_only)
    return RegressionResult(run_id=info.run_id, config=config, changes=changes, rerun=rerun, comparison=comparison,
                            undecodable_recorded=bad, notes=notes, recorded_config=info.config_text,
                            recorded_config_name=label)


def calibration_notes(recorded: FswConfig, changed: FswConfig) -> list[str]:
    """A warning when the detector keeps a calibration made for its network's recorded
    parameters while those parameters changed: thresholds and false-alarm rate are properties
    of the weights a network produces, and a batch size changes even what one weight is."""
    cal = changed.detector.calibration
    net = changed.detector.network
    if cal is None or cal != recorded.detector.calibration or recorded.detector.network != net:
        return []
    before = {g.network: g.params for g in recorded.gating}.get(net)
    after = {g.network: g.params for g in changed.gating}.get(net)
    if before is None or after is None or before == after:
        return []
    diffs = [f"{f.name} {getattr(before, f.name)!r} -> {getattr(after, f.name)!r}" for f in dataclasses.fields(after)
             if getattr(before, f.name) != getattr(after, f.name)]
    return [f"the detector's calibration was made for {net} as recorded; this re-run changes {', '.join(diffs)}, so "
            "its thresholds and false-alarm rate do not apply to these weights (re-calibrate with `navbank calibrate`)"]


def _when(t_s: float) -> str:
    """A TDB epoch as ISO 8601 UTC, with the raw seconds for cross-reference."""
    try:
        return f"{tdb_to_utc_iso(t_s, 0)} UTC, t_s {t_s:.1f}"
    except (TimeError, ValueError):
        return f"t_s {t_s:.1f}"


def _fmt(x: float) -> str:
    return "0" if x == 0.0 else f"{x:.3g}"


def format_result(res: RegressionResult, largest: int = 10) -> str:
    """The table ``navbank replay --rerun`` prints."""
    c = res.comparison
    mode = res.config.budget.mode
    lines = [f"re-run of run {res.run_id or '?'}: {res.rerun.measurements} measurements through a fresh FSW "
             f"({mode} budget mode) in {res.rerun.elapsed_s:.1f} s"]
    lines.append("configuration: " + ("recorded, changed by " + " ".join(res.changes) if res.changes else "as recorded"))
    if res.rerun.undecodable:
        lines.append(f"  {res.rerun.undecodable} recorded measurement payloads did not decode (fed raw, counted by the FSW)")
    width = max([len("topic")] + [len(t) for t in c.topics])
    lines.append(f"{'topic':<{width}}  {'recorded':>8}  {'re-run':>8}  {'max |diff|':>10}  {'max rel':>8}  "
                 f"{'mismatch':>8}  worst field")
    for t in c.topics.values():
        if not t.compared:
            lines.append(f"{t.topic:<{width}}  {t.recorded:>8}  {t.rerun:>8}  {'-':>10}  {'-':>8}  {'-':>8}  ({t.note})")
            continue
        mark = "" if t.identical(c.tolerance) else "  <--"
        lines.append(f"{t.topic:<{width}}  {t.recorded:>8}  {t.rerun:>8}  {_fmt(t.max_abs):>10}  {_fmt(t.max_rel):>8}  "
                     f"{t.mismatches:>8}  {t.worst_field() or '-'}{mark}")
    rows = c.largest(largest)
    if rows:
        lines.append("largest differences:")
        for topic, name, f in rows:
            at = f" at message {f.worst_index}" if f.worst_index >= 0 else ""
            if f.worst_t_s is not None:
                at += f" ({_when(f.worst_t_s)})"
            what = (f"{f.mismatches} mismatches, e.g. {f.example}" if f.mismatches
                    else f"|diff| {_fmt(f.max_abs)}, relative {_fmt(f.max_rel)}"
                    + (f" ({f.outside} outside the tolerances)" if f.outside and c.rtol > 0.0 else ""))
            if c.rtol > 0.0 and not f.mismatches and f.worst_rel_index >= 0:
                at = f" at message {f.worst_rel_index}"
                if f.worst_rel_t_s is not None:
                    at += f" ({_when(f.worst_rel_t_s)})"
            lines.append(f"  {topic} {name}: {what}{at}")
    one_sided = sorted({k for t in c.topics.values() for k in t.one_sided})
    if one_sided:
        lines.append("status counters on one side only (process transport counters, not compared): " + ", ".join(one_sided))
    for note in res.notes:
        lines.append("note: " + note)
    tol = f"tolerance {c.tolerance:g}" + (f", relative tolerance {c.rtol:g}" if c.rtol > 0.0 else "")
    lines.append(f"result: {'IDENTICAL' if c.identical else 'DIFFERENT'} ({tol})")
    return "\n".join(lines)

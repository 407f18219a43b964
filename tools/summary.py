"""The plain-words report ``navbank run`` prints from a run's summary.

The summary itself is computed on the ground (:func:`ground.report.run_summary.summarize`).
"""

from __future__ import annotations

from ground.report.summary_types import RunSummary


def describe(summary: RunSummary) -> str:
    """The plain-words report ``navbank run`` prints."""
    s = summary
    lines = [f"scenario {s.scenario}  seed {s.seed}  fault {s.fault.preset or s.fault.fault_class}"]
    for ev in s.fault.events:
        if ev.event == "start":
            mag = ", ".join(f"{k} {v:g}" for k, v in ev.magnitude.items())
            lines.append(f"  injected {ev.type} ({mag}) on day {ev.day:.2f}")
    mc = s.measurements
    lines.append(f"measurements: {mc.published} published, {mc.processed} processed, "
                 f"{mc.rejected} rejected, {mc.lost} lost")
    lines.append("filters: " + ", ".join(s.filters))
    for net, g in s.gating.items():
        mw = "  ".join(f"{f} {w:.3f}" for f, w in g.mean_weights.items())
        lines.append(f"mean weights [{net}]: {mw}")
        if g.mean_weights_after_onset is not None:
            mw = "  ".join(f"{f} {w:.3f}" for f, w in g.mean_weights_after_onset.items())
            lines.append(f"   after onset [{net}]: {mw}")
    a = s.anomaly
    if not a.detector:
        lines.append("anomaly detector OFF: the scenario has no detector calibration (see `navbank calibrate`)")
    elif a.declared:
        when = f"day {a.time_day:.2f}"
        if a.false_alarm:
            lines.append(f"ANOMALY declared on {when} by {a.network}: {a.anomaly_class} (confidence {a.confidence:.2f}) "
                         f"-- a FALSE ALARM (before any injected fault)")
        else:
            verdict = "correct" if a.correct_class else f"WRONG (injected {a.true_class})"
            assert a.latency_s is not None  # a declaration at or after the true onset has its latency
            lines.append(f"ANOMALY declared on {when} by {a.network}: {a.anomaly_class} (confidence {a.confidence:.2f}), "
                         f"{a.latency_s / 3600:.1f} h after the true onset; diagnosis {verdict}")
    else:
        if a.onset_true is None:
            lines.append("no anomaly declared (none injected)")
        else:
            lines.append(f"no anomaly declared -- MISSED the injected {a.true_class} fault")
    if s.position_error_rms_km:
        lines += _position_lines(s)
    if s.bplane:
        lines.append("B-plane (Mars mean equator) at the last epoch: B·R, B·T ± 1σ [km]; error vs truth [km]; "
                     "closest approach error ± 1σ [s]:")
        for label in [lb for lb in ("combined", "best") if lb in s.bplane] or list(s.bplane)[:2]:
            bp = s.bplane[label]

            def err(v: float | None, fmt: str) -> str:
                return "-" if v is None else format(v, fmt)

            lines.append(f"  {label:<9} {bp.b_dot_r_km:9.1f} ± {bp.b_dot_r_sigma_km:.1f}  {bp.b_dot_t_km:9.1f} ± "
                         f"{bp.b_dot_t_sigma_km:.1f};  {err(bp.b_dot_r_error_km, '+.1f')}, {err(bp.b_dot_t_error_km, '+.1f')};  "
                         f"{err(bp.periapsis_error_s, '+.1f')} ± {bp.periapsis_sigma_s:.1f}")
    b = s.budget
    lines.append(f"budget ({b.mode}): {b.frames} frames, max utilisation {b.max_utilisation:.2f}, "
                 f"{b.overruns} overruns, max backlog {b.max_backlog}, final backlog {b.final_backlog}")
    if b.stage_cpu_us:
        lines.append("  CPU per measurement by stage: "
                     + ", ".join(f"{label} {us:.1f} µs" for label, us in b.stage_cpu_us.items()))
    if s.commands:
        # a commanded run says so: a command can change what every line above reports
        changed = [c for c in s.commands if c.ok and c.command != "status"]
        refused = sum(not c.ok for c in s.commands)
        lines.append(f"telecommands: {len(s.commands)} served, {len(changed)} changed the FSW, {refused} refused")
        for c in changed[:10]:
            what = " ".join(f"{k} {v}" for k, v in (("network", c.network), ("filter", c.filter), ("param", c.param),
                                                     ("value", c.value)) if v is not None)
            lines.append(f"  day {c.day:6.2f}  {c.command} {what}".rstrip())
        if len(changed) > 10:
            lines.append(f"  ... and {len(changed) - 10} more (summary.json lists them all)")
    if s.measurements.unprocessed is not None:
        lines.append(f"stopped with {s.measurements.unprocessed} measurements delivered to the FSW but not processed")
    if s.restarts is not None and s.restarts.events:
        # a restarted run says so, and what the restarts cost the recording
        for r in s.restarts.events:
            where = "" if r.checkpoint_day is None else \
                f", went on from its checkpoint on day {r.checkpoint_day:.2f} ({r.checkpoint_measurements} measurements)"
            if r.resent is not None:
                where += f"; {r.resent} measurements sent again"
            lines.append(f"restart: the {r.process} process ended with code {r.exit_code} {r.at_wall_s:.1f} s into the run{where}")
        twice = sum(s.restarts.duplicates_dropped.values())
        lost = ", ".join(f"{t} {n}" for t, n in s.restarts.gaps.items()) or "nothing"
        lines.append(f"  recorded twice and dropped: {twice}; never recorded: {lost}")
    if s.refused and any(s.refused.values()):
        lines.append(f"REFUSED (failed authentication, changed nothing): {s.refused.get('telecommands', 0)} telecommands, "
                     f"{s.refused.get('statuses', 0)} statuses or drain queries (see /fsw/commands and /_refused/)")
    if s.wall_time_s is not None:
        lines.append(f"wall time {s.wall_time_s:.1f} s")
    return "\n".join(lines)


#: What the two bank solutions are (fsw.core.fswcore: _emit_estimates, _best_filter).
COMBINED_BEST = ("combined = the gating-weighted sum of the enabled filters' estimates "
                 "(Chaer et al. 1997 eq. 3, weights of the detector's network{net})",
                 "best = the filter navigated on: the one with the smallest position uncertainty (RTPC) "
                 "until an anomaly is declared, then the one with the highest weight")


def _position_lines(s: RunSummary) -> list[str]:
    """Errors against truth per solution: RMS over the run, at the last estimate, and how often
    the error was within 3 sigma (|error| <= 3 RTPC: a consistent filter is there ~97-100 % of the time)."""
    labels = list(s.position_error_rms_km)
    width = max(len(x) for x in labels)
    # a filter that reported no estimate with truth beside it has no final error or 3-sigma figure
    lines = ["position error RMS, final [km] and estimates within 3 sigma, against truth:"]
    for label in labels:
        final = s.position_error_final_km.get(label)
        within = s.position_within_3sigma.get(label)
        lines.append(f"  {label:<{width}}  {s.position_error_rms_km[label]:>10.3f} "
                     f"{'-' if final is None else f'{final:9.3f}':>9} "
                     f"{'-' if within is None else f'{100 * within:12.0f} %':>14}")
    if "combined" in labels or "best" in labels:
        net = f", {s.anomaly.network}" if s.anomaly.network else ""
        lines += ["  " + COMBINED_BEST[0].format(net=net), "  " + COMBINED_BEST[1]]
    return lines

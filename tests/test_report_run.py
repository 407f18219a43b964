"""Run report: extraction of the plotted arrays, the figures themselves, report.md.

The arrays are checked on a hand-made message list against values computed here with plain
Python (math.dist, subtraction), and the figures against the Line2D data actually drawn.
"""

from __future__ import annotations

import math
import random
import struct
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from fsw.interface import messages as m, topics
from ground.report import run_plots
from ground.report.build import report_run_messages
from ground.report.run_data import extract
from ground.report.run_facts import run_facts

T0 = 600_000_000.0
DAY = 86400.0
S = m.Stamp(sec=1_700_000_000, nsec=0)
FILTERS = ("radio", "optical", "fused")
STATES_CLOCK = ("rx", "ry", "rz", "vx", "vy", "vz", "clock_phase", "clock_frequency")
STATES_NOCLOCK = ("rx", "ry", "rz", "vx", "vy", "vz")


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def _truth(k: int) -> m.Truth:
    t = T0 + 600.0 * k
    return m.Truth(t_s=t, timestamp=S, position_km=(1.0e5 + 3.0 * k, -2.0e4 + k, 5.0e3), velocity_km_s=(1.0, 0.0, 0.0),
                   clock_phase_s=1.0e-7 * k, clock_frequency=0.0, clock_drift_per_s=0.0)


def _estimate(label: str, k: int, d: tuple[float, float, float], phase: float | None) -> m.Estimate:
    tr = _truth(k)
    pos = tuple(a + b for a, b in zip(tr.position_km, d))
    names = STATES_CLOCK if phase is not None else STATES_NOCLOCK
    state = pos + (1.0, 0.0, 0.0) + ((phase, 0.0) if phase is not None else ())
    sigma = (1.0,) * len(names)
    if phase is not None:
        sigma = sigma[:6] + (2.0e-6, 1e-13)
    return m.Estimate(t_s=tr.t_s + 1.0e-5, timestamp=S, filter=label, position_km=pos, velocity_km_s=(1.0, 0.0, 0.0),
                      position_sigma_km=0.5 + 0.1 * k, state_names=names, state=state, sigma=sigma)


@pytest.fixture(scope="module")
def hand_made() -> list[tuple[str, object]]:
    msgs: list[tuple[str, object]] = [
        (topics.SIM_STATUS, m.RunStatus(t_s=T0, timestamp=S, run_id="hm", source="sim", state="start")),
        (topics.SIM_FAULTS, m.FaultEvent(t_s=T0 + 1.5 * DAY, timestamp=S, fault_id="f0", fault_type="optical-bias",
                                         event="start", fault_class="optical-measurement", magnitude={"sample_px": 2.0})),
    ]
    msgs += [(topics.SIM_TRUTH, _truth(k)) for k in range(0, 60)]
    # estimates every 6th truth epoch (hourly grid); one estimate at an epoch with no truth
    for k in range(0, 60, 6):
        msgs.append(("/fsw/estimate/radio", _estimate("radio", k, (3.0, 4.0, 0.0), 1.0e-7 * k + 5.0e-7)))
        msgs.append(("fsw/estimate/optical", _estimate("optical", k, (0.0, 0.0, 0.1 * k + 0.1), None)))
    msgs.append(("fsw/estimate/radio", _estimate("radio", 100, (1.0, 0.0, 0.0), 0.0)))
    for b in range(5):
        w = (0.2 + 0.1 * b, 0.5 - 0.1 * b, 0.3)
        msgs.append((f"{topics.FSW_WEIGHTS}/chi2", m.FilterWeights(t_s=T0 + 3600.0 * (b + 1), timestamp=S, network="chi2",
                                                                    batch=b, filters=FILTERS, weights=w)))
    # a batch with a filter disabled: its weight is absent, not zero
    msgs.append((f"{topics.FSW_WEIGHTS}/chi2", m.FilterWeights(t_s=T0 + 3600.0 * 6, timestamp=S, network="chi2", batch=5,
                                                                filters=("radio", "fused"), weights=(0.6, 0.4))))
    for i, (day, flag, stat) in enumerate([(0.2, False, 0.5), (1.0, False, 1.0), (1.7, True, 6.0), (2.0, True, 7.0),
                                           (2.2, False, 1.0), (2.4, True, 8.0)]):
        t = T0 + day * DAY
        msgs.append((topics.FSW_ANOMALY, m.AnomalyReport(
            t_s=t, timestamp=S, flag=flag, anomaly_class="optical-measurement" if flag else "none",
            confidence=0.9 if flag else 0.0, onset_s=T0 + 1.6 * DAY if flag else None, declared_s=t if flag else None,
            network="chi2", statistic=stat, threshold=4.0)))
    for f in range(4):
        msgs.append((topics.FSW_BUDGET, m.BudgetReport(frame=f, t_s=T0 + 60.0 * (f + 1), timestamp=S, mode="work-units",
                                                       used=float(f), budget=2.0, utilisation=f / 2.0, processed=f,
                                                       deferred=max(0, f - 2), backlog=f % 2, overruns=0)))
    for i, kind in enumerate(("range", "doppler", "optical", "doppler")):
        value, sigma = ((1.0, 2.0), (0.1, 0.1)) if kind == "optical" else ((1.0,), (0.1,))
        msgs.append((topics.SIM_MEASUREMENTS, m.Measurement(
            seq=i, t_s=T0 + 100.0 * i, timestamp=S, kind=kind, source="mars" if kind == "optical" else "DSS-14",
            value=value, sigma=sigma, attitude_q=(1.0, 0.0, 0.0, 0.0) if kind == "optical" else None)))
    msgs.append(("fsw/unknown-topic", {"x": 1}))
    msgs.append((topics.FSW_BUDGET, b"\x00undecodable"))
    random.Random(7).shuffle(msgs)  # a complete MCAP file is read in receive order, not epoch order
    return msgs


def test_position_error_is_estimate_minus_truth_at_matched_epochs(hand_made):
    data = extract(hand_made)
    radio = data.position["radio"]
    ks = list(range(0, 60, 6))
    want = [math.dist(_estimate("radio", k, (3.0, 4.0, 0.0), 0.0).position_km, _truth(k).position_km) for k in ks]
    assert radio.error == pytest.approx(want, rel=1e-12)
    assert radio.error == pytest.approx([5.0] * len(ks), rel=1e-9)  # a 3-4-5 offset
    assert radio.unmatched == 1
    assert radio.sigma == pytest.approx([0.5 + 0.1 * k for k in ks])
    opt = data.position["optical"]
    assert opt.error == pytest.approx([0.1 * k + 0.1 for k in ks], rel=1e-6)
    assert data.day(radio.t_s) == pytest.approx([600.0 * k / DAY for k in ks], abs=1e-9)


def test_clock_error_only_for_filters_that_estimate_a_clock(hand_made):
    data = extract(hand_made)
    assert set(data.clock) == {"radio"}
    ks = list(range(0, 60, 6))
    assert data.clock["radio"].error == pytest.approx([5.0e-7] * len(ks), rel=1e-9)
    assert data.clock["radio"].sigma == pytest.approx([2.0e-6] * len(ks))


def test_weights_trace_sorted_with_absent_filter_as_nan(hand_made):
    tr = extract(hand_made).weights["chi2"]
    assert tr.filters == FILTERS
    assert list(tr.batch) == [0, 1, 2, 3, 4, 5]
    assert tr.weights[:5, 0] == pytest.approx([0.2, 0.3, 0.4, 0.5, 0.6])
    assert tr.weights[:5, 1] == pytest.approx([0.5, 0.4, 0.3, 0.2, 0.1])
    assert math.isnan(tr.weights[5, 1]) and tr.weights[5, 2] == pytest.approx(0.4)


def test_anomaly_declarations_are_rising_edges(hand_made):
    data = extract(hand_made)
    decl = data.anomaly.declarations
    assert [round((d.t_s - T0) / DAY, 6) for d in decl] == [1.7, 2.4]
    assert data.skipped == 2


def test_plotted_lines_carry_the_data(hand_made):
    data = extract(hand_made)
    fig = run_plots.plot_weights(data, "chi2")
    lines = {ln.get_label(): ln for ln in fig.axes[0].lines}
    assert np.asarray(lines["radio"].get_ydata(), float)[:5] == pytest.approx([0.2, 0.3, 0.4, 0.5, 0.6])
    assert np.asarray(lines["radio"].get_xdata(), float) == pytest.approx([(b + 1) / 24.0 for b in range(6)])
    assert fig.axes[0].get_ylim() == pytest.approx((-0.02, 1.02))
    vlabels = [lb for lb in lines if lb.startswith(("fault onset", "anomaly declared"))]
    assert vlabels == ["fault onset day 1.50 (optical-bias)", "anomaly declared day 1.70: optical-measurement",
                       "anomaly declared day 2.40: optical-measurement"]

    fig = run_plots.plot_position_error(data, "radio")
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    lines = {ln.get_label(): ln for ln in ax.lines}
    assert np.asarray(lines["position error |r̂ − r|"].get_ydata(), float) == pytest.approx([5.0] * 10, rel=1e-9)
    assert np.asarray(lines["3σ RTPC"].get_ydata(), float) == pytest.approx(3.0 * data.position["radio"].sigma)
    assert "[km]" in ax.get_ylabel() and "[days]" in ax.get_xlabel()

    fig = run_plots.plot_clock_phase(data, "radio")
    lines = {ln.get_label(): ln for ln in fig.axes[0].lines}
    assert np.asarray(lines["clock phase error (estimate − truth)"].get_ydata(), float) == pytest.approx([0.5] * 10)  # µs
    assert "[µs]" in fig.axes[0].get_ylabel()


def test_write_run_figures_and_markdown(hand_made, tmp_path):
    paths = report_run_messages(hand_made, tmp_path)
    names = {p.name for p in paths}
    assert {"weights_chi2.png", "position_error_radio.png", "position_error_optical.png", "position_error_all.png",
            "clock_phase_radio.png", "anomaly_statistic.png", "budget.png", "measurements.png", "report.md"} <= names
    for p in paths:
        if p.suffix == ".png":
            w, h = png_size(p)
            assert 900 <= w <= 1400 and 250 <= h <= 800, (p.name, w, h)
    md = (tmp_path / "report.md").read_text()
    for p in paths:
        if p.suffix == ".png":
            assert f"]({p.name})" in md
    assert "declared on day 1.70 by chi2: optical-measurement" in md
    assert "Numbers from the recorded messages" in md
    assert md.startswith("# navbank run report: hm\n")  # the run id, not a file name


def test_plot_nits(hand_made):
    data = extract(hand_made)
    fig = run_plots.plot_anomaly_statistic(data)
    assert fig.axes[0].get_ylim()[0] == 0.0  # a non-negative statistic gets no negative region
    fig = run_plots.plot_budget(data)
    assert all(ax.get_ylim()[0] >= 0.0 for ax in fig.axes)
    fig = run_plots.plot_position_errors_all(data)
    lines = {ln.get_label(): ln for ln in fig.axes[0].lines}
    declared = [ln for lb, ln in lines.items() if lb.startswith("anomaly declared")]
    assert declared and all(ln.get_color() == run_plots.DECLARATION_COLOR != "black" for ln in declared)


# --- a real (short) run: the whole path from the FSW's messages to report.md ------------------

@pytest.fixture(scope="module")
def short_run():
    import dataclasses as dc

    from fsw.config import GatingEntry
    from fsw.fdir.config import DetectorConfig
    from tools.inprocess import run_in_process
    from tools.scenario import load_scenario, with_fault

    cfg = with_fault(load_scenario("insight-approach"), "optical-bias-large", onset_day=1.0)
    cfg = dc.replace(cfg, sim=dc.replace(cfg.sim, trajectory=dc.replace(cfg.sim.trajectory, span_days=2.0)))
    s2 = 0.03**2
    cal = DetectorConfig(network="chi2", filters=FILTERS, nominal_mean=(1 / 3,) * 3,
                         nominal_cov=((s2, 0, 0), (0, s2, 0), (0, 0, s2)), threshold=4.0, clear_threshold=2.0,
                         onset_reference=1.0, persistence_k=2, persistence_n=3, hold=3)
    banks = GatingEntry.of("hierarchical", groups={"radiometric": ("radio",), "imaging": ("optical", "fused")})
    fsw = dc.replace(cfg.fsw, gating=(GatingEntry.of("chi2", batch_size=100), GatingEntry.of("magill"), banks),
                     detector=dc.replace(cfg.fsw.detector, calibration=cal))
    return run_in_process(dc.replace(cfg, fsw=fsw), 5)


def test_facts_agree_with_the_run_summary(short_run):
    facts = run_facts(extract(short_run.messages))
    ref = short_run.summary.to_json()
    for key in ("position_error_rms_km", "position_error_final_km", "position_within_3sigma"):
        assert facts[key].keys() == ref[key].keys()
        for label in ref[key]:
            assert facts[key][label] == pytest.approx(ref[key][label], rel=1e-12)
    for net, g in ref["gating"].items():
        for span in ("mean_weights", "mean_weights_after_onset", "final_weights"):
            if span in g:
                assert facts["gating"][net][span] == pytest.approx(g[span], rel=1e-9)
    for key in ("declared", "time", "latency_s", "class", "true_class", "false_alarm", "correct_class"):
        assert facts["anomaly"][key] == ref["anomaly"][key]
    assert facts["budget"]["max_backlog"] == ref["budget"]["max_backlog"]


def test_report_of_a_recorded_run_directory(short_run, tmp_path):
    import json

    from ground.mcap_io import McapRecorder
    from ground.report.build import report
    from tools.scenario import to_yaml

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    with McapRecorder(run_dir / "run.mcap") as rec:
        for i, (topic, msg) in enumerate(short_run.messages):
            rec.write_message(topic, msg, log_time_ns=1_700_000_000_000_000_000 + 1000 * i)
    (run_dir / "summary.json").write_text(json.dumps(short_run.summary.to_json()))
    (run_dir / "config.yaml").write_text(to_yaml(short_run.config))
    paths = report(run_dir)
    assert all(p.parent == run_dir / "report" for p in paths)
    names = {p.name for p in paths}
    assert {"weights_chi2.png", "weights_magill.png", "weights_hierarchical.png", "hierarchy_hierarchical.png",
            "position_error_fused.png", "clock_phase_fused.png", "anomaly_statistic.png", "budget.png",
            "measurements.png", "report.md"} <= names
    assert "hierarchy_chi2.png" not in names
    assert "clock_phase_optical.png" not in names  # the optical-only filter has no clock state
    for p in paths:
        if p.suffix == ".png":
            assert p.stat().st_size > 10_000
            png_size(p)
    md = (run_dir / "report" / "report.md").read_text()
    assert "Numbers from summary.json" in md and "| scenario | insight-approach |" in md
    assert "## Hierarchical gating 'hierarchical': mean bank weights" in md and "Banks: the run's configuration." in md
    # the one-filter bank's in-bank weight is 1 by construction, whatever the run did
    assert "| radiometric | radio |" in md and "radio 1.00" in md

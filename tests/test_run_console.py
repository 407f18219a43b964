"""What ``navbank run`` shows on the console: the progress bar and the plain-words summary."""

from __future__ import annotations

import io
import json

import pytest

from ground.report.summary_types import RunSummary
from test_summary_types import RUN_SUMMARY
from tools.progress import advance_to, fsw_progress, progress_bar
from tools.summary import describe


def _summary() -> RunSummary:
    data = json.loads(RUN_SUMMARY)
    data["position_error_rms_km"].update(combined=2.0, best=3.25)
    data["position_error_final_km"].update(combined=0.75, best=1.0)
    data["position_within_3sigma"].update(combined=1.0, best=0.5)
    return RunSummary.from_json(data)


def test_summary_shows_final_error_and_3sigma_and_says_what_combined_and_best_are():
    lines = describe(_summary()).splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("position error RMS"))
    rows = {ln.split()[0]: ln.split()[1:] for ln in lines[start + 1:start + 4]}
    assert rows == {"radio": ["2.500", "1.500", "98", "%"], "combined": ["2.000", "0.750", "100", "%"],
                    "best": ["3.250", "1.000", "50", "%"]}
    combined, best = lines[start + 4:start + 6]
    assert "combined = the gating-weighted sum" in combined and "chi2" in combined
    assert "best = the filter navigated on" in best and "until an anomaly is declared" in best


def test_summary_says_where_the_fsw_cpu_went_stage_by_stage():
    # a run in budget mode cpu: the FSW's last status counts each stage label's CPU; the summary
    # gives it per processed measurement, largest first, and the console prints it
    from fsw.interface import topics
    from tools.bench.core import scenario
    from tools.inprocess import run_in_process

    run = run_in_process(scenario(0.25), 1)
    status = run.topic(topics.FSW_STATUS)[-1]
    processed = status.counts["processed"]
    stages = run.summary.budget.stage_cpu_us
    assert run.summary.budget.mode == "cpu" and processed > 100
    assert list(stages) == sorted(stages, key=lambda k: -stages[k]) and list(stages)[0] == "bank"
    assert stages == pytest.approx({k: status.counts[f"stage_cpu_us_{k}"] / processed for k in stages}, rel=1e-12)
    line = next(ln for ln in describe(run.summary).splitlines() if "CPU per measurement by stage" in ln)
    assert f"bank {stages['bank']:.1f} µs" in line and "gating" in line
    assert RunSummary.from_json(json.loads(json.dumps(run.summary.to_json()))).budget.stage_cpu_us == stages
    # work units say nothing of the host's CPU: no line
    assert _summary().budget.stage_cpu_us is None
    assert not any("CPU per measurement" in ln for ln in describe(_summary()).splitlines())


def test_fsw_progress_line_is_read_from_the_fsw_own_format():
    from fsw.app import _progress_line
    from fsw.core.fswcore import FswCore
    from tools.scenario import load_scenario, resolve

    cfg, _ = resolve(load_scenario("insight-approach"))
    core = FswCore(cfg.fsw, lambda *a: None, run_id="x")
    core.start()
    day, rest = fsw_progress(_progress_line(core))
    assert day == 0.0 and rest.startswith("processed 0, rejected 0")
    assert fsw_progress("fsw: day  25.3  processed 12  rejected 0  backlog 1  anomaly none done") == (
        25.3, "processed 12, rejected 0, backlog 1, anomaly none done")
    assert fsw_progress("some warning") is None


def test_progress_bar_in_a_log_is_whole_lines_with_percentage_and_eta():
    buf = io.StringIO()
    bar = progress_bar(45.0, desc="run x", unit="day", stream=buf)
    advance_to(bar, 22.5, "processed 100")
    bar.refresh()
    advance_to(bar, 45.0)
    bar.close()
    text = buf.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert lines[-1].startswith("run x 100%") and "45.0/45.0 day" in lines[-1] and "ETA" in lines[-1]
    assert any(" 50%" in ln and "22.5/45.0 day" in ln and "processed 100" in ln for ln in lines)


def test_campaign_progress_counts_runs_failures_and_eta():
    from tools.campaign.progress import CampaignProgress

    buf = io.StringIO()
    p = CampaignProgress(3, label="c", stream=buf)
    p.update(running=2)
    p.update(finished=1, running=2)
    p.update(finished=1, failed=1, running=1, note="interrupted", force=True)
    p.update(finished=1, running=0)
    p.close()
    last = buf.getvalue().splitlines()[-1]
    assert last.startswith("c 100%") and "3/3 runs" in last and "ETA" in last
    assert "1 failed" in last and "interrupted" in last

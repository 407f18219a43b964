"""The core's pipeline: the stage table, the jobs built from it, and the end of a run."""

from __future__ import annotations

from collections import Counter

import pytest

from fsw.core import FswCore
from fsw.core.pipeline import JobContext, Load, StageSpec, bank_cost, build_job, gating_cost
from fsw.executive import BudgetConfig
from fsw.filters.record import BankRecord
from fsw.interface import messages as m, topics
from fsw.interface.messages import Stamp
from sim.stream import generate
from tools.scenario import load_text_scenario, resolve

SCENARIO = """\
name: pipeline
seed: 3
sim:
  trajectory: {span_days: 1.0}
fsw:
  gating:
    - {network: chi2, batch_size: 150}
    - {network: magill}
  budget: {mode: work-units, work_unit_budget: 10.0}
"""


def _measurement(seq: int, t: float) -> m.Measurement:
    return m.Measurement(seq=seq, t_s=t, timestamp=Stamp(0, 0), kind="range", source="DSS-14",
                         value=(1.0e5,), sigma=(0.001,))


def test_the_table_runs_ingest_bank_gating_telemetry_in_that_order():
    rows = [(s.kind, s.label) for s in FswCore.PIPELINE]
    assert rows == [("ingest", None), ("primary", "bank"), ("gating", None), ("telemetry", None)]


def test_declared_costs_follow_the_load():
    b = BudgetConfig(ingest_cost=1.0, primary_cost=10.0, filters_cost=4.0, gating_cost=3.0, telemetry_cost=2.0)
    # one primary filter plus 4 work units per further enabled filter; 3 per network, at least one
    assert bank_cost(b, Load(active_filters=1, networks=0)) == 10.0
    assert bank_cost(b, Load(active_filters=4, networks=0)) == 22.0
    assert gating_cost(b, Load(active_filters=4, networks=0)) == 3.0
    assert gating_cost(b, Load(active_filters=4, networks=5)) == 15.0


class _Recorder:
    """A stand-in core: each stage notes its name and what the previous stages left in the context."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, object]] = []

    def first(self, ctx: JobContext) -> None:
        self.calls.append(("first", ctx.record))
        ctx.record = BankRecord.__new__(BankRecord)  # any object: the next stage must see this one

    def second(self, ctx: JobContext) -> None:
        self.calls.append(("second", ctx.record))


def test_a_job_binds_every_row_to_the_core_and_one_context():
    rec = _Recorder()
    table = (StageSpec("primary", "a", _Recorder.first, lambda b, load: 7.0),
             StageSpec("gating", None, _Recorder.second, lambda b, load: float(load.networks)))
    job = build_job(rec, table, _measurement(5, 100.0), BudgetConfig(), Load(active_filters=2, networks=3))
    assert (job.t, job.tag) == (100.0, "5")
    assert [(s.kind, s.label, s.cost) for s in job.stages] == [("primary", "a", 7.0), ("gating", "gating", 3.0)]
    for s in job.stages:
        s.fn(job.context)
    assert rec.calls[0] == ("first", None)
    assert rec.calls[1][0] == "second" and rec.calls[1][1] is not None


# -- the end of a run -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def flown():
    cfg, seed = resolve(load_text_scenario(SCENARIO))
    run = generate(cfg.sim, seed=seed)
    out: list[tuple[str, object]] = []
    core = FswCore(cfg.fsw, lambda topic, msg: out.append((topic, msg)), run_id="p")
    core.start()
    for meas in run.measurements:
        core.ingest(meas)
    n_before_finish = len(out)
    end = core.finish()
    return core, out, n_before_finish, end, len(run.measurements)


def test_finish_ends_with_the_status_counting_every_message_before_it(flown):
    core, out, _, end, n_meas = flown
    assert out[-1] == (topics.FSW_STATUS, end) and end.state == "end-of-run" and end.source == "fsw"
    emitted = Counter(topic for topic, _ in out[:-1])
    assert {k: v for k, v in end.counts.items() if "/" in k} == dict(emitted)
    assert end.counts["processed"] + end.counts["rejected"] == n_meas and end.counts["pending"] == 0
    assert end.counts["backlog"] == 0 and core.finished


def test_finish_drains_the_backlog_and_closes_the_partial_batch(flown):
    core, out, n_before, end, _ = flown
    tail = out[n_before:]
    budget = [msg for topic, msg in tail if topic == topics.FSW_BUDGET]
    assert budget and budget[-1].backlog == 0  # the starved budget left work for the end of the run
    chi2 = [msg for topic, msg in out if topic == "fsw/weights/chi2"]
    magill = [msg for topic, msg in out if topic == "fsw/weights/magill"]
    # chi2 publishes per batch of 150: the last, partial one is closed at the end; magill holds nothing back
    assert len(chi2) == -(-core.bank.processed_count // 150)
    assert len(magill) == core.bank.processed_count
    assert chi2[-1].t_s == magill[-1].t_s
    # every estimate stream ends at the last epoch
    last = {topic: msg for topic, msg in out if topic.startswith(topics.FSW_ESTIMATE)}
    assert {msg.t_s for msg in last.values()} == {end.t_s}


def test_each_drained_frame_reports_right_after_its_work(flown):
    _, out, n_before, _, _ = flown
    tail = [(topic, msg) for topic, msg in out[n_before:] if topic in (topics.FSW_BUDGET, "fsw/weights/magill")]
    # magill publishes per measurement: during the drain each frame's weights come out before that
    # frame's report and are no later than its end, frame after frame
    frames: list[tuple[list[float], float]] = []
    pending: list[float] = []
    for topic, msg in tail:
        if topic == topics.FSW_BUDGET:
            frames.append((pending, msg.t_s))
            pending = []
        else:
            pending.append(msg.t_s)
    busy = [(ts, end) for ts, end in frames if ts]
    assert len(busy) > 10
    assert all(max(ts) <= end for ts, end in busy)


def test_finish_is_done_once(flown):
    core, out, _, end, _ = flown
    n = len(out)
    assert core.finish() is end and len(out) == n


def test_networks_without_held_back_evidence_flush_nothing():
    cfg, _ = resolve(load_text_scenario(SCENARIO))
    core = FswCore(cfg.fsw, lambda topic, msg: None)
    assert core.networks["magill"].flush() is None
    assert core.networks["chi2"].flush() is None  # an empty batch

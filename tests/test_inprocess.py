"""The in-process runner's memory handling: the collector is off during a run, and the run's
cyclic garbage is freed when it ends, without a full collection of the process."""

from __future__ import annotations

import dataclasses
import gc

from tools.inprocess import collector_held, run_in_process
from tools.scenario import load_scenario


def _short_run():
    cfg = load_scenario("insight-approach")
    sim = dataclasses.replace(cfg.sim, faults=(),
                              trajectory=dataclasses.replace(cfg.sim.trajectory, span_days=0.5))
    return dataclasses.replace(cfg, sim=sim)


def test_a_run_leaves_no_cyclic_garbage_behind():
    cfg = _short_run()
    run_in_process(cfg, 1)  # first use: lazily built tables are not the run's garbage
    gc.collect()
    threshold = gc.get_threshold()
    gc.set_threshold(0)  # no automatic collection: only the runner's own may run before the count
    try:
        result = run_in_process(cfg, 2)
        assert result.summary.measurements.processed > 0
        # what a full collection still finds is what the runner's collection missed
        assert gc.collect() < 50
    finally:
        gc.set_threshold(*threshold)


def test_only_the_result_holds_the_messages():
    """The FSW core is freed only by the collector (it lives in reference cycles); its sink must
    not keep the run's messages with it, or dropping a result frees nothing until a collection
    traverses them all."""
    with collector_held():  # as a campaign task holds it: the core is not collected yet
        result = run_in_process(_short_run(), 1)
        holders = [r for r in gc.get_referrers(result.messages) if r is not result and r is not vars(result)]
    assert holders == []


def test_the_collector_is_back_on_after_a_run():
    assert gc.isenabled()
    run_in_process(_short_run(), 1)
    assert gc.isenabled()

"""The same campaign on the local spawn pool and on a dask LocalCluster gives the same runs."""

import dataclasses
import io
import json

import pytest

from tools.campaign.executors import DaskExecutor, LocalExecutor
from tools.campaign.plan import expand
from tools.campaign.runner import run_campaign
from tools.campaign.spec import load_campaign
from tools.campaign.stats import compute_directory
from ground.report.row_types import ResultRow
from tools.campaign.store import read_rows

CAMPAIGN = """\
name: optical-short
seeds: {count: 3, base: 1}
onset_day: 1.0
matrix:
  - scenarios: [short.yaml]
    faults: [none, optical-bias-small, optical-bias-medium, optical-bias-large]
"""


def _comparable(row: ResultRow) -> tuple:
    return row.status, row.seed, row.cell, dataclasses.replace(row.summary, wall_time_s=None)


@pytest.mark.slow
def test_local_and_dask_give_the_same_runs(tmp_path, short_scenario):
    (tmp_path / "short.yaml").write_text(short_scenario(2.5))
    (tmp_path / "c.yaml").write_text(CAMPAIGN)
    plan = expand(load_campaign(str(tmp_path / "c.yaml")))
    assert len(plan.tasks) == 12
    results = {}
    for name, factory in (("local", lambda: LocalExecutor(2)), ("dask", lambda: DaskExecutor(2))):
        out = tmp_path / name
        stream = io.StringIO()
        outcome = run_campaign(plan, out, factory, progress_stream=stream)
        assert outcome.finished == 12 and outcome.failed == 0 and not outcome.interrupted
        assert outcome.executor == name and outcome.workers == 2
        assert "12/12" in stream.getvalue() and "ETA" in stream.getvalue()
        rows = read_rows(out / "runs.jsonl")
        assert len(rows.rows) == 12 and not rows.torn_tail
        assert {r.executor for r in rows.rows} == {name}
        results[name] = {r.id: _comparable(r) for r in rows.rows}
    assert set(results["local"]) == {t.id for t in plan.tasks} == set(results["dask"])
    for rid in results["local"]:
        assert results["local"][rid] == results["dask"][rid], rid
    # the runs carry what the statistics need: the optical bias moves chi2's weight to the radio filter
    s = compute_directory(tmp_path / "local").to_json()
    (t,) = [t for t in s["weight_tables"] if t["network"] == "chi2"]
    after = {r["case"]: r["after_onset"] for r in t["rows"] if r["after_onset"]}
    assert after["optical-bias-large"]["radio"] > 0.5 > after["optical-bias-small"]["radio"]
    json.dumps(s)


@pytest.mark.slow
def test_local_cluster_workers_keep_the_default_allocator():
    """dask's nanny would start the workers with MALLOC_TRIM_THRESHOLD_ (freed memory handed back
    to the OS at once), which costs every run ~4.5 % CPU; our LocalCluster leaves it out."""
    import os

    import dask
    import distributed  # noqa: F401  (registers the distributed configuration)

    assert "MALLOC_TRIM_THRESHOLD_" in dask.config.get("distributed.nanny.pre-spawn-environ")
    executor = DaskExecutor(1)
    try:
        seen = executor.client.run(os.getenv, "MALLOC_TRIM_THRESHOLD_")
        threads = executor.client.run(os.getenv, "OPENBLAS_NUM_THREADS")
    finally:
        executor.close()
    assert list(seen.values()) == [None]
    assert list(threads.values()) == ["1"]  # the rest of dask's worker environment is kept


@pytest.mark.slow
def test_local_cluster_event_loops_wake_less_often():
    """Every wake of a worker's event loop takes the GIL from the run: our LocalCluster's
    scheduler, nannies and workers get longer periods than dask's defaults (tick 20 ms, system
    monitor 500 ms, memory monitor 100 ms)."""
    executor = DaskExecutor(1)
    try:
        def periods(server: object) -> dict[str, float]:
            pcs = server.periodic_callbacks  # type: ignore[attr-defined]
            return {k: pcs[k].callback_time for k in ("tick", "monitor", "memory_monitor") if k in pcs}

        workers = executor.client.run(lambda dask_worker: periods(dask_worker))
        scheduler = executor.client.run_on_scheduler(lambda dask_scheduler: periods(dask_scheduler))
        nannies = [periods(n) for n in executor.cluster.workers.values()]  # type: ignore[union-attr]
    finally:
        executor.close()
    assert list(workers.values()) == [{"tick": 1000, "monitor": 5000, "memory_monitor": 1000}]
    assert scheduler == {"tick": 1000, "monitor": 5000}
    assert nannies == [{"tick": 1000, "monitor": 5000, "memory_monitor": 1000}]

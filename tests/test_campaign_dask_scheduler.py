"""A campaign against a real dask cluster: ``dask scheduler`` and two ``dask worker`` processes on
127.0.0.1, reached by address (``navbank campaign --executor dask --scheduler ADDR``), gives the
same runs as the local executor."""

from __future__ import annotations

import dataclasses
import time

import pytest

from ground.report.row_types import ResultRow
from tools.campaign.dask_cluster import LoopbackCluster, dask_cli
from tools.campaign.executors import DaskExecutor, LocalExecutor
from tools.campaign.plan import expand
from tools.campaign.runner import run_campaign
from tools.campaign.spec import load_campaign
from tools.campaign.store import read_rows

CAMPAIGN = """\
name: dask-scheduler
seeds: {count: 2, base: 7}
onset_day: 0.5
matrix:
  - scenarios: [short.yaml]
    faults: [none, optical-bias-large]
"""


def _comparable(row: ResultRow) -> tuple:
    assert row.summary is not None
    return row.status, row.seed, row.cell, dataclasses.replace(row.summary, wall_time_s=None)


def test_the_dask_cli_is_installed():
    (exe,) = dask_cli()
    assert exe.endswith("dask")


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_campaign_on_a_real_dask_scheduler_equals_the_local_executor(tmp_path, short_scenario):
    (tmp_path / "short.yaml").write_text(short_scenario(1.5))
    (tmp_path / "c.yaml").write_text(CAMPAIGN)
    plan = expand(load_campaign(str(tmp_path / "c.yaml")))
    assert len(plan.tasks) == 4
    local = run_campaign(plan, tmp_path / "local", lambda: LocalExecutor(2), quiet=True)
    assert local.finished == 4 and local.failed == 0
    t0 = time.monotonic()
    with LoopbackCluster(2, start_timeout_s=60.0) as cluster:
        assert cluster.address.startswith("tcp://127.0.0.1:")
        worker_pids = {p.pid for p in cluster.processes()[:2]}
        import distributed

        with distributed.Client(cluster.address, timeout=30) as client:
            # the preload keeps dask's statistical profiler off the workers (tools.campaign.warm)
            profiling = client.run(lambda dask_worker: sorted(k for k in dask_worker.periodic_callbacks
                                                              if k.startswith("profile")))
            # and wakes their event loops less often (dask's defaults: tick 20 ms, monitors 500/100 ms)
            periods = client.run(lambda dask_worker: {k: dask_worker.periodic_callbacks[k].callback_time
                                                      for k in ("tick", "monitor", "memory_monitor")})
        assert len(profiling) == 2 and all(v == [] for v in profiling.values()), profiling
        assert all(p == {"tick": 1000.0, "monitor": 5000.0, "memory_monitor": 1000.0} for p in periods.values()), periods
        outcome = run_campaign(plan, tmp_path / "dask", lambda: DaskExecutor(2, cluster.address), quiet=True)
        procs = cluster.processes()
    # torn down: every process the cluster started has exited
    assert all(p.poll() is not None for p in procs)
    assert time.monotonic() - t0 < 240.0
    assert outcome.finished == 4 and outcome.failed == 0 and outcome.executor == "dask" and outcome.workers == 2
    rows = {r.id: r for r in read_rows(tmp_path / "dask" / "runs.jsonl").rows}
    expected = {r.id: r for r in read_rows(tmp_path / "local" / "runs.jsonl").rows}
    assert set(rows) == set(expected) == {t.id for t in plan.tasks}
    # the runs ran in the separate dask worker processes, not in this one
    assert {r.pid for r in rows.values()} <= worker_pids
    for rid, row in rows.items():
        assert row.executor == "dask" and expected[rid].executor == "local"
        assert _comparable(row) == _comparable(expected[rid]), rid


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_cluster_whose_workers_cannot_start_is_torn_down_with_their_logs():
    cluster = LoopbackCluster(2, start_timeout_s=60.0, preload="navbank_no_such_module")
    with pytest.raises((RuntimeError, TimeoutError)) as err:
        cluster.__enter__()
    assert "navbank_no_such_module" in str(err.value)
    procs = cluster.processes()
    assert len(procs) == 3 and all(p.poll() is not None for p in procs)

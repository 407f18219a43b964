"""Frame executive ordering: per-lane time order, in-job stage order, priority and FIFO policies."""

import random

import pytest

from fsw.executive import BudgetConfig, FrameExecutive, Job, Stage
from fsw.executive.schedule import StageQueue

FILTERS = ("radio", "optical", "fused")


def bank_job(t, log, cost=5.0, filters=FILTERS):
    """One measurement's work: ingest, primary filter, other filters (own lanes), gating, telemetry."""

    def step(label):
        return lambda: log.append((label, t))

    stages = [Stage("ingest", step("ingest"), cost=cost), Stage("primary", step("primary"), cost=cost)]
    stages += [Stage("filters", step(f"filter:{f}"), lane=f"filter:{f}", cost=cost) for f in filters[1:]]
    stages += [Stage("gating", step("gating"), cost=cost), Stage("telemetry", step("telemetry"), cost=cost)]
    return Job(t=t, stages=tuple(stages))


def check_constraints(log, jobs_stage_labels):
    """Independent check of the ordering rules on the recorded execution order."""
    by_label: dict[str, list[float]] = {}
    position = {}
    for i, (label, t) in enumerate(log):
        by_label.setdefault(label, []).append(t)
        assert (label, t) not in position, f"stage {label} of job {t} ran twice"
        position[(label, t)] = i
    for label, times in by_label.items():
        assert times == sorted(times), f"lane {label} ran out of time order"
    for t, labels in jobs_stage_labels.items():
        idx = [position[(label, t)] for label in labels]
        assert idx == sorted(idx), f"job {t} stages out of order"


def wu_config(**kw):
    return BudgetConfig(mode="work-units", **kw)


@pytest.mark.parametrize("policy", ["priority", "fifo"])
def test_every_stage_runs_once_in_order_under_overload(policy):
    log = []
    ex = FrameExecutive(wu_config(work_unit_budget=15.0, policy=policy))
    times = [30.0 + 60.0 * k for k in range(12)]
    for t in times:
        ex.submit(bank_job(t, log))
    ex.run_until(times[-1] + 60.0)
    result = ex.drain()
    assert result.remaining_jobs == 0
    labels = ["ingest", "primary", "filter:optical", "filter:fused", "gating", "telemetry"]
    assert len(log) == len(times) * len(labels)
    check_constraints(log, {t: labels for t in times})
    # gating of a measurement only after every filter processed it
    pos = {entry: i for i, entry in enumerate(log)}
    for t in times:
        assert all(pos[("gating", t)] > pos[(f, t)] for f in labels[1:4])


def test_priority_policy_keeps_primary_current_while_other_filters_lag():
    log = []
    ex = FrameExecutive(wu_config(work_unit_budget=10.0))  # 2 stages of cost 5 per frame
    for k in range(6):
        ex.submit(bank_job(30.0 + 60.0 * k, log))
        ex.run_frame()
        progress = ex.lane_progress()
        # ingest + primary of the new measurement fill the frame: the navigation solution is current
        assert progress["primary"] == 30.0 + 60.0 * k
        assert "filter:optical" not in progress
    assert ex.backlog == 6


def test_fifo_policy_completes_one_job_at_a_time():
    log = []
    ex = FrameExecutive(wu_config(work_unit_budget=10.0, policy="fifo"))
    for k in range(3):
        ex.submit(bank_job(30.0 + 60.0 * k, log))
    ex.drain()
    labels = ["ingest", "primary", "filter:optical", "filter:fused", "gating", "telemetry"]
    assert log == [(label, 30.0 + 60.0 * k) for k in range(3) for label in labels]


def test_everything_fitting_runs_breadth_first_by_priority():
    log = []
    ex = FrameExecutive(wu_config(work_unit_budget=1000.0))
    for t in (1.0, 2.0, 3.0):
        ex.submit(bank_job(t, log))
    report = ex.run_frame()
    assert report.processed == 18 and report.backlog == 0 and report.deferred == 0
    kinds = [label for label, _ in log]
    expected = ["ingest"] * 3 + ["primary"] * 3
    assert kinds[:6] == expected
    assert kinds[-6:] == ["gating"] * 3 + ["telemetry"] * 3


def test_random_job_shapes_respect_lane_and_stage_order():
    rng = random.Random(7)
    kinds = ("ingest", "primary", "filters", "gating", "telemetry")
    log = []
    jobs = {}
    ex = FrameExecutive(wu_config(work_unit_budget=7.0))
    t = 0.0
    for j in range(60):
        t += rng.choice((0.0, 5.0, 50.0, 200.0))
        n = rng.randint(1, 5)
        stages, labels = [], []
        for s in range(n):
            lane = rng.choice(("a", "b", "c", "d"))
            kind = rng.choice(kinds)
            # record (lane, job) so each lane's time order can be checked; one lane use per job
            if lane in labels:
                continue
            labels.append(lane)
            key = (lane, j)
            stages.append(Stage(kind, (lambda key=key: log.append(key)), lane=lane, cost=rng.choice((1.0, 2.0, 3.0))))
        jobs[j] = labels
        ex.submit(Job(t=t, stages=tuple(stages)))
        ex.run_until(t)
    ex.drain()
    assert ex.stats.jobs_completed == 60
    # lane order is job order; job order is stage order
    check_constraints(log, jobs)


def test_job_not_run_before_its_time_tag():
    log = []
    ex = FrameExecutive(wu_config(work_unit_budget=1000.0), t0=0.0)
    ex.submit(bank_job(100.0, log))
    first = ex.run_frame()  # ends at 60 s
    assert first.processed == 0 and first.backlog == 0 and first.deferred == 0
    second = ex.run_frame()  # ends at 120 s
    assert second.processed == 6 and log[0] == ("ingest", 100.0)


def _scan_pick(queue):
    """The priority rule written out independently: among lane heads (each lane's first
    outstanding stage, jobs in order) that are their job's next stage, the lowest (priority
    rank, job order)."""
    first: dict[str, tuple[object, int]] = {}
    for state in queue._jobs:
        for index in range(state.next, len(state.job.stages)):
            first.setdefault(state.job.stages[index].lane_key, (state, index))
    heads = list(first.values())
    ready = [(state.job.stages[index].rank, state.order, state, index) for state, index in heads if state.next == index]
    if not ready:
        return None
    rank, order, state, index = min(ready, key=lambda r: (r[0], r[1]))
    return state, index


@pytest.mark.parametrize("policy", ["priority", "fifo"])
def test_a_stage_completed_out_of_order_is_refused_with_one_job_or_many(policy):
    """complete() refuses a stage that is not its job's next, or (under fifo, or with one job
    outstanding) not the oldest outstanding job's — with the lanes kept and without them — and
    a refused completion leaves the queue as it was (the stages then complete in order)."""
    from fsw.executive.schedule import JobState

    def job(t):
        return JobState(Job(t=t, stages=(Stage("ingest", lambda: None), Stage("gating", lambda: None))), int(t))

    queue = StageQueue(policy)
    a = job(0.0)
    queue.add(a)
    with pytest.raises(RuntimeError, match="out of order"):
        queue.complete(a, 1)  # its second stage before its first
    queue.complete(a, 0)
    b = job(1.0)
    queue.add(b)  # two jobs outstanding: the priority policy keeps lanes from here on
    with pytest.raises(RuntimeError, match="out of order"):
        queue.complete(b, 1)
    if policy == "fifo":
        with pytest.raises(RuntimeError, match="out of order"):
            queue.complete(b, 0)  # fifo: the younger job waits for the older one
        queue.complete(a, 1)
        queue.complete(b, 0)
    else:
        queue.complete(b, 0)  # its lane (ingest) is free: allowed ahead of a's gating
        queue.complete(a, 1)
    assert queue.complete(b, 1) and queue.pending_jobs == 0 and queue.pending_stages == 0
    assert queue.peek() is None


def test_priority_peek_matches_the_rule_with_one_job_or_many():
    """peek takes a shortcut while one job is outstanding; with random jobs (own lanes, shared
    lanes, one-stage jobs) arriving and stages completing, it picks what the rule picks."""
    from fsw.executive.schedule import JobState, StageQueue

    rng = random.Random(7)
    kinds = ("ingest", "primary", "filters", "gating", "telemetry")
    shortcut = 0
    for trial in range(200):
        queue = StageQueue("priority")
        order = 0
        for _ in range(rng.randint(1, 40)):
            if rng.random() < 0.4 or queue.pending_jobs == 0:
                n = rng.randint(1, 5)
                stages = tuple(Stage(rng.choice(kinds), lambda: None, lane=rng.choice((None, "a", "b")))
                               for _ in range(n))
                queue.add(JobState(Job(t=float(order), stages=stages), order))
                order += 1
            expected = _scan_pick(queue)
            shortcut += queue.pending_jobs == 1
            picked = queue.peek()
            assert (picked is None) == (expected is None)
            if picked is None:
                continue
            assert picked[0] is expected[0] and picked[1] == expected[1]
            queue.complete(*picked)
    assert shortcut > 100  # the shortcut was exercised


def _reference_frames(jobs, policy, budget, frame_s, n_frames):
    """The executive's frames written out naively, for comparison: every stage picked by the
    rule of the policy over every due job (no shortcuts), admitted while its declared cost fits
    the budget left (the first stage of a frame always), charged its declared cost."""
    progress = [0] * len(jobs)  # next stage index per job
    log, reports = [], []
    for k in range(n_frames):
        t_end = (k + 1) * frame_s
        used, processed = 0.0, 0
        while True:
            ready = []
            for j, job in enumerate(jobs):
                i = progress[j]
                if job.t > t_end or i >= len(job.stages):
                    continue
                lane = job.stages[i].lane_key
                # ready: every earlier due job has passed this lane (lanes are FIFO by job)
                blocked = any(jobs[e].t <= t_end and any(s.lane_key == lane for s in jobs[e].stages[progress[e]:])
                              for e in range(j))
                if not blocked:
                    ready.append((job.stages[i].rank if policy == "priority" else 0, j, i))
            if policy == "fifo":
                ready = [r for r in ready if all(progress[e] >= len(jobs[e].stages) or jobs[e].t > t_end
                                                 for e in range(r[1]))]
            if not ready:
                break
            _, j, i = min(ready)
            cost = jobs[j].stages[i].cost
            if processed and cost > budget - used:
                break
            log.append((k, j, i))
            used += cost
            processed += 1
            progress[j] += 1
        reports.append((processed, used))
    return log, reports


@pytest.mark.parametrize("policy", ["priority", "fifo"])
def test_frames_run_what_the_naive_rule_runs(policy, monkeypatch):
    """Random jobs (shared and own lanes, one to five stages, bursts and gaps), random costs,
    a budget that defers: the executive runs, frame by frame, the stages the naive rule picks.
    Its shortcut for a frame whose remaining work is one job's is taken often."""
    rng = random.Random(23)
    kinds = ("ingest", "primary", "filters", "gating", "telemetry")
    frame_s = 60.0
    shortcut = peeks = 0
    policy_pick = StageQueue.peek

    def counted_peek(queue):
        nonlocal peeks
        peeks += 1
        return policy_pick(queue)

    monkeypatch.setattr(StageQueue, "peek", counted_peek)  # the queue is slotted: counted on its class
    for trial in range(40):
        log = []
        jobs = []
        t = 0.0
        for j in range(rng.randint(1, 25)):
            t += rng.choice((0.0, 5.0, 30.0, 60.0, 200.0))
            n = rng.randint(1, 5)
            stages = tuple(Stage(rng.choice(kinds), (lambda j=j, i=i: log.append((j, i))),
                                 lane=rng.choice((None, None, "a", "b")), cost=float(rng.randint(1, 6)))
                           for i in range(n))
            jobs.append(Job(t=t, stages=stages))
        budget = float(rng.choice((3, 6, 10, 15, 100)))
        ex = FrameExecutive(wu_config(work_unit_budget=budget, policy=policy, frame_s=frame_s), t0=0.0)
        for job in jobs:
            ex.submit(job)
        n_frames = int(t / frame_s) + 2 + sum(len(job.stages) for job in jobs)  # a stage a frame at least
        got_log, got_reports = [], []
        for k in range(n_frames):
            before, asked = len(log), peeks
            rep = ex.run_frame()
            if peeks == asked:
                shortcut += len(log) - before
            got_log += [(k, j, i) for j, i in log[before:]]
            got_reports.append((rep.processed, rep.used))
        want_log, want_reports = _reference_frames(jobs, policy, budget, frame_s, n_frames)
        assert got_log == want_log, trial
        assert got_reports == want_reports, trial
        assert ex.pending_jobs == 0
    assert shortcut > 200  # stages of frames that never asked the policy: the one-job shortcut

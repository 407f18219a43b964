"""Frame executive in CPU mode: charging measured thread CPU x cpu_scale, admission by learned cost,
and a real CPU-burning workload (asserting structure, not timing)."""

import time

from fsw.executive import BudgetConfig, FrameExecutive, Job, Stage


class FakeClock:
    """A CPU clock that only the stages advance."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now

    def burn(self, seconds):
        def fn():
            self.now += seconds
        return fn


def test_cpu_scale_multiplies_the_measured_cost():
    clock = FakeClock()
    cfg = BudgetConfig(mode="cpu", cpu_budget_s=1.0, cpu_scale=4.0)
    ex = FrameExecutive(cfg, clock=clock)
    ex.submit(Job(t=0.0, stages=(Stage("primary", clock.burn(0.1)),)))
    report = ex.run_frame()
    assert report.mode == "cpu" and report.budget == 1.0
    assert abs(report.used - 0.4) < 1e-12 and abs(report.utilisation - 0.4) < 1e-12
    assert abs(ex.stats.cpu_measured_s - 0.1) < 1e-12


def test_a_clock_that_misbehaves_charges_nothing():
    """A reading that goes backwards, is NaN or is infinite (a broken or wrapped clock) charges
    the stage it ends 0 CPU: the frame reports a finite use and the executive goes on."""
    clock = FakeClock()

    def jump(to):
        def fn():
            clock.now = to
        return fn

    cfg = BudgetConfig(mode="cpu", cpu_budget_s=1.0, cpu_scale=2.0)
    ex = FrameExecutive(cfg, clock=clock)
    stages = (Stage("primary", clock.burn(0.25), name="a"), Stage("gating", jump(0.1), name="backwards"),
              Stage("gating", jump(float("nan")), name="nan"), Stage("gating", jump(0.5), name="after-nan"),
              Stage("gating", jump(float("inf")), name="inf"), Stage("gating", jump(0.75), name="after-inf"),
              Stage("telemetry", clock.burn(0.125), name="b"))
    ex.submit(Job(t=0.0, stages=stages))
    report = ex.run_frame()
    assert report.processed == len(stages) and report.overruns == 0
    # only the two well-measured stages are charged: (0.25 + 0.125) x cpu_scale
    assert report.used == 0.75 and ex.stats.cpu_measured_s == 0.375


def test_the_cpu_of_each_stage_label_is_what_its_stages_measured():
    """Per label: the stages run and the CPU measured in them, cold first runs included,
    unscaled; a misbehaving clock reading adds nothing; work units know no CPU."""
    clock = FakeClock()
    cfg = BudgetConfig(mode="cpu", cpu_budget_s=10.0, cpu_scale=3.0)
    ex = FrameExecutive(cfg, clock=clock)
    for k in range(4):
        ex.submit(Job(t=float(k), stages=(Stage("primary", clock.burn(0.25)), Stage("gating", clock.burn(0.125)),
                                          Stage("telemetry", clock.burn(0.0625 * k)))))
        ex.run_frame(float(k) + 0.5)
    assert ex.stage_cpu() == {"primary": (4, 1.0), "gating": (4, 0.5), "telemetry": (4, 0.375)}
    assert sum(cpu for _, cpu in ex.stage_cpu().values()) == ex.stats.cpu_measured_s

    def backwards():
        clock.now -= 1.0

    ex.submit(Job(t=10.0, stages=(Stage("gating", backwards),)))
    ex.run_frame(10.5)
    assert ex.stage_cpu()["gating"] == (5, 0.5)
    assert FrameExecutive(BudgetConfig(mode="work-units")).stage_cpu() == {}


def test_admission_learns_the_cost_and_stops_overrunning():
    """Stages of 3 ms against a 10 ms budget: once the cost is learned, exactly 3 run per frame
    (a 4th would need 12 ms) and no frame overruns."""
    clock = FakeClock()
    cfg = BudgetConfig(mode="cpu", cpu_budget_s=0.010, cpu_scale=1.0)
    ex = FrameExecutive(cfg, clock=clock)
    for k in range(120):
        ex.submit(Job(t=float(k), stages=(Stage("primary", clock.burn(0.003)),)))
    result = ex.drain()
    assert result.remaining_jobs == 0
    per_frame = [r.processed for r in result.reports]
    assert all(1 <= n <= 3 for n in per_frame)
    assert per_frame[-10:-1] == [3] * 9
    assert ex.stats.overruns == 0
    mean, dev = ex.cost_estimates()["primary"]
    assert abs(mean - 0.003) < 1e-9 and dev < 1e-4


def test_slow_stage_beyond_its_estimate_is_an_overrun():
    clock = FakeClock()
    unit = 2.0**-10  # binary fractions: the fake clock adds them without rounding
    cfg = BudgetConfig(mode="cpu", cpu_budget_s=8 * unit, cpu_scale=1.0)
    ex = FrameExecutive(cfg, clock=clock)
    costs = [unit] * 20 + [32 * unit] + [unit] * 5
    for k, c in enumerate(costs):
        ex.submit(Job(t=float(k), stages=(Stage("filters", clock.burn(c)),)))
    reports = ex.drain().reports
    assert ex.stats.overruns == 1
    (hit,) = [r for r in reports if r.utilisation > 1.0]
    assert hit.used >= 32 * unit and hit.overruns == 1


def burn_cpu(seconds):
    """Spin until this thread has used ``seconds`` of CPU (bounded by wall time on a stalled host)."""
    start = time.thread_time()
    deadline = time.monotonic() + 50 * seconds + 1.0
    x = 0
    while time.thread_time() - start < seconds and time.monotonic() < deadline:
        x += 1
    return x


def burning_run(cpu_scale, n_jobs=24, cost_s=0.002):
    order = []
    cfg = BudgetConfig(mode="cpu", cpu_budget_s=0.010, cpu_scale=cpu_scale)
    ex = FrameExecutive(cfg)  # real time.thread_time
    for k in range(n_jobs):
        stages = tuple(
            Stage(kind, (lambda kind=kind, k=k: (burn_cpu(cost_s), order.append((kind, k)))))
            for kind in ("primary", "filters")
        )
        ex.submit(Job(t=float(k), stages=stages))
    reports = ex.drain().reports
    return ex, reports, order


def test_real_cpu_burn_is_measured_and_budgeted():
    ex, reports, order = burning_run(cpu_scale=1.0)
    # each stage costs at least 2 ms of thread CPU, so at most 5 fit a 10 ms frame
    assert all(1 <= r.processed <= 5 for r in reports)
    assert sum(r.processed for r in reports) == 48 and ex.stats.jobs_completed == 24
    assert len(reports) >= 48 // 5
    assert all(r.used >= 0.002 * r.processed for r in reports)
    assert reports[-1].backlog == 0 and max(r.backlog for r in reports) > 0
    for kind in ("primary", "filters"):
        ks = [k for kd, k in order if kd == kind]
        assert ks == sorted(ks) and len(ks) == 24


def test_real_cpu_burn_on_a_slower_processor_overruns_every_frame():
    # charged >= 2 ms x 10 = 20 ms > 10 ms budget: one stage per frame, each an overrun
    ex, reports, order = burning_run(cpu_scale=10.0, n_jobs=6)
    assert [r.processed for r in reports] == [1] * 12
    assert [r.overruns for r in reports] == list(range(1, 13))
    assert all(r.utilisation >= 2.0 for r in reports)
    assert len(order) == 12


def test_a_cold_first_run_does_not_starve_the_stage_afterwards():
    # The first run of a stage carries one-time costs (20x here); the stage must still be admitted
    # beside others as soon as its typical cost fits, not be held to one per frame for hours.
    clock = FakeClock()
    unit = 2.0**-10
    cfg = BudgetConfig(mode="cpu", cpu_budget_s=10 * unit, cpu_scale=1.0)
    ex = FrameExecutive(cfg, clock=clock)
    costs = [20 * unit] + [unit] * 39
    for k, c in enumerate(costs):
        ex.submit(Job(t=0.0 + k * 1e-3, stages=(Stage("primary", clock.burn(c), name="bank"),)))
    first = ex.run_frame(60.0)
    assert first.processed == 1 and first.overruns == 1  # the cold run overran its frame
    second = ex.run_frame(120.0)
    assert second.processed >= 5  # afterwards several typical runs share a frame again


def test_the_meter_follows_the_running_mean_and_deviation_rule_label_by_label():
    """CpuMeter against the rule of its docstring written out here: per label, the first charge
    seeds nothing; the second sets mean = cost and deviation = cost / 2; each later one moves
    both by the gain (mean toward the cost, deviation toward |cost − mean|); the prediction is
    mean + margin × deviation, 0 while there is no mean; a stage fits while the budget left is
    positive and not below it. Random labels, costs and budgets, compared exactly."""
    import copy
    import pickle
    import random

    from fsw.executive.meter import CpuMeter

    rng = random.Random(5)
    cfg = BudgetConfig(mode="cpu", cpu_scale=3.0, cost_gain=0.3, cost_margin=2.5)
    meter = CpuMeter(cfg)
    seen: dict[str, int] = {}
    mean: dict[str, float] = {}
    dev: dict[str, float] = {}
    labels = ("ingest", "bank", "gating", "telemetry", "rqp")
    stages = {lab: Stage("primary", lambda: None, name=lab) for lab in labels}

    def predicted(lab):
        return mean[lab] + cfg.cost_margin * dev[lab] if lab in mean else 0.0

    for step in range(3000):
        lab = rng.choice(labels)
        stage = stages[lab]
        remaining = rng.choice((-1.0, 0.0, rng.uniform(0.0, 0.02), 1.0))
        assert meter.predict(stage) == predicted(lab)
        assert meter.fits(stage, remaining) == (remaining > 0.0 and predicted(lab) <= remaining)
        assert meter.admits(meter.predict(stage), remaining) == meter.fits(stage, remaining)
        measured = rng.choice((0.0, rng.uniform(0.0, 0.003), rng.uniform(0.0, 0.05)))
        cost = measured * cfg.cpu_scale
        assert meter.charge(stage, measured) == cost
        n = seen.get(lab, 0)
        seen[lab] = n + 1
        if n == 0:
            pass
        elif lab not in mean:
            mean[lab], dev[lab] = cost, 0.5 * cost
        else:
            err = cost - mean[lab]
            mean[lab] += cfg.cost_gain * err
            dev[lab] += cfg.cost_gain * (abs(err) - dev[lab])
        if step == 1500:  # a copy or a checkpoint carries the estimates on exactly
            meter = pickle.loads(pickle.dumps(copy.deepcopy(meter)))
    assert meter.estimates() == {lab: (mean[lab], dev[lab]) for lab in mean}
    assert list(meter.estimates()) == list(mean)  # in the order the labels got an estimate


class Burn:
    """A stage that burns ``seconds`` of a FakeClock (picklable, unlike FakeClock.burn's)."""

    def __init__(self, clock, seconds):
        self.clock, self.seconds = clock, seconds

    def __call__(self):
        self.clock.now += self.seconds


def test_the_executive_keeps_no_instance_dictionary_to_be_converted_by_a_copy():
    """The executive, its queue and its meters are slotted (see FrameExecutive): a copy or a
    checkpoint reads their slots, and the copy runs on as the original does."""
    import copy
    import pickle

    from fsw.executive.meter import WorkUnitMeter

    clock = FakeClock()
    ex = FrameExecutive(BudgetConfig(mode="cpu", cpu_budget_s=0.010, cpu_scale=1.0), clock=clock)
    for k in range(6):
        ex.submit(Job(t=1.0 * k, stages=(Stage("primary", Burn(clock, 0.004)), Stage("gating", Burn(clock, 0.001)))))
    ex.run_frame()
    ex.run_frame()
    for obj in (ex, ex._queue, ex._meter, WorkUnitMeter(BudgetConfig())):
        assert not hasattr(obj, "__dict__"), type(obj).__name__
    twins = (copy.deepcopy(ex), pickle.loads(pickle.dumps(ex)))
    pending = ex.pending_jobs
    want = ex.drain().reports
    assert len(want) >= 2 and ex.pending_jobs == 0
    for twin in twins:
        assert twin._lock is not ex._lock
        assert twin.pending_jobs == pending > 0
        assert twin.drain().reports == want
        assert twin.stats == ex.stats and twin.cost_estimates() == ex.cost_estimates()

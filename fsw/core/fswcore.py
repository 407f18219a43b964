"""The flight software's core: bank, gating networks and anomaly detector under the executive.

``FswCore`` is transport-free and deterministic in work-unit budget mode: the FSW process feeds it
measurements from Zenoh and publishes what it emits, the in-process runner and the replay
re-run feed it from memory or from an MCAP file. All three run the same code, from
:meth:`FswCore.start` to :meth:`FswCore.finish`.

Time is driven by the data: before a measurement tagged t is queued, every frame ending before t
runs (so a gap in tracking gives the executive idle frames to catch up its backlog). Each
measurement becomes one executive job whose stages are the rows of :attr:`FswCore.PIPELINE`:

``ingest``    bookkeeping (cheap);
``primary``   the filter bank — all filters are advanced in one vectorised stage, because they
              share the propagation of the union state and per-filter stages would cost more
              than the whole bank; its work-unit cost scales with the number of filters;
``gating``    every gating network, then the detector on the configured network's new weights;
``telemetry`` estimates, anomaly reports and status at their configured cadences.

Nothing is dropped: a measurement the bank rejects is counted by reason and its gating stage
skipped; a stage that raises is contained and counted by the executive.
"""

from __future__ import annotations

import copy
import dataclasses
import gc
import time
from collections.abc import Sequence
from typing import Callable, ClassVar, cast

import numpy as np

from fsw.config import FswConfig, InitialState
from fsw.core import commands
from fsw.core.adaptation import OnboardRqp, report_message
from fsw.core.counters import CoreCounters, ExtraCounters, status_counts
from fsw.core.pipeline import (JobContext, Load, StageSpec, bank_cost, build_stages, gating_cost,
                               ingest_cost, no_gc_pauses, telemetry_cost)
from fsw.core.telemetry import (AnomalyReporter, Emit, FswMessage, RunState, bplane_message, budget_message,
                                command_record, estimate_message, residual_samples, residuals_message, status_message,
                                weights_message)
from fsw.executive import BudgetReportData, FrameExecutive
from fsw.executive.work import Job, Stage
from fsw.fdir.detector import AnomalyDetector, AnomalyState
from fsw.filters.adaptive_q import linprog_solver
from fsw.filters.bank import FilterBank, FilterEstimate
from fsw.filters.orbit_bank import OrbitBank
from fsw.filters.errors import MeasurementRejected
from fsw.filters.record import BankRecord
from fsw.gating.base import GatingError, GatingNetwork, WeightsUpdate, check_record
from fsw.gating.registry import make_network
from fsw.ingest import SequenceGuard
from fsw import kernels
from fsw.interface import codec, messages as m, topics

#: Label of the pipeline's filter-bank stage: a measurement is processed once it has run.
BANK_STAGE = "bank"


class FswCore:
    """Bank + gating + detector + executive; emits ICD telemetry through ``emit(topic, msg)``."""

    # Slotted, as the objects it runs per measurement are (see fsw.executive.FrameExecutive): the
    # warm-up copies the core and a checkpoint pickles it while it flies.
    __slots__ = ("config", "run_id", "_sink", "record_taps", "bank", "filters", "networks", "latest",
                 "_weights_topics", "reporter", "guard", "counters", "taken", "executive", "_stages",
                 "_warm_kinds", "t0", "_next_estimate", "_next_anomaly", "_next_status", "_residuals",
                 "_next_residuals", "_next_bplane", "_last_t", "_end", "extra_counters", "_last_overruns",
                 "_next_idle_report", "frames_reported", "max_utilisation", "rqp")

    def __init__(self, config: FswConfig, emit: Emit, *, run_id: str = "run",
                 clock: Callable[[], float] = time.thread_time):
        if config.initial_state is None:
            raise ValueError("the FSW needs an a-priori initial state (fsw.initial_state)")
        #: Ground observers of every bank record the core makes (post-processing re-runs, e.g. EM
        #: tuning); never set onboard. A start-up warm-up copy has none: what it flies is thrown away.
        self.record_taps: tuple[Callable[[BankRecord], None], ...] = ()
        kernels.load_all()  # the models' kernels, compiled or loaded now, not in the first frames
        self.config = config
        self.run_id = run_id
        self._sink = emit
        init: InitialState = config.initial_state
        if config.central_body == "earth":
            # the Earth-orbit bank offers every FilterBank method the core calls (RQP, the one
            # user of the rest, is refused with it at configuration)
            self.bank = cast(FilterBank, OrbitBank.from_config(config.bank, init.t_s, init.position_km,
                                                               init.velocity_km_s))
        else:
            self.bank = FilterBank(config.bank, init.t_s, init.position_km, init.velocity_km_s)
        if any(f.process_noise.mode != "fixed" for f in config.bank.filters):
            linprog_solver()  # loaded while the core is built, not in the frame of the first adaptive-Q LP
        self.filters = tuple(self.bank.names)
        self.networks: dict[str, GatingNetwork] = {
            g.network: make_network(g.network, self.filters, g.params) for g in config.gating
        }
        self.latest: dict[str, WeightsUpdate] = {}
        self._weights_topics: dict[str, str] = {}  # network -> its topic, made once
        det = config.detector
        self.reporter: AnomalyReporter | None = None
        if det.calibration is not None:
            self.reporter = AnomalyReporter(AnomalyDetector(det.calibration, config.families()))
        self.guard = SequenceGuard(window=config.reorder_window, t_start=init.t_s,
                                   max_ahead_s=config.intake.max_ahead_s,
                                   max_sequence_jump=config.intake.max_sequence_jump)
        self.counters = CoreCounters()
        #: measurement payloads taken so far (decodable or not): where a served command sits in the stream
        self.taken = 0
        # a stage that raises is contained and counted by the executive (BudgetReport.errors)
        self.executive = FrameExecutive(config.budget, clock=clock, t0=init.t_s)
        #: the pipeline's stages bound to this core, per load (enabled filters, networks, adaptive
        #: LP work units): the same for every job of that load; a job is they and its context
        self._stages: dict[tuple[bytes, int, float], tuple[Stage, ...]] = {}
        #: measurement kinds whose first job has been flown on a copy (:meth:`_warm_up`); None:
        #: no warm-up (work-unit budgets do not depend on the host's start-up costs)
        self._warm_kinds: set[str] | None = set() if config.budget.mode == "cpu" else None
        self.t0 = init.t_s
        self._next_estimate = init.t_s
        self._next_anomaly = init.t_s
        self._next_status = init.t_s + config.telemetry.status_every_s
        #: the records (with their measurements' sources) whose residuals the next Residuals
        #: message carries: their samples are made when it is sent (:meth:`_emit_residuals`)
        self._residuals: list[tuple[BankRecord, str]] = []
        self._next_residuals = init.t_s + (config.telemetry.residuals_every_s or 0.0)
        self._next_bplane = init.t_s
        self._last_t = init.t_s
        self._end: m.RunStatus | None = None
        #: counters of the process around the core (e.g. malformed telecommands), in every status
        self.extra_counters: ExtraCounters | None = None
        self._last_overruns = 0
        self._next_idle_report = init.t_s
        self.frames_reported = 0
        self.max_utilisation = 0.0
        #: RQP adaptation of the best filter (Chaer et al. 1997 §IV); idle unless enabled
        self.rqp = OnboardRqp(config.rqp, config.budget)

    # -- checkpoints (fsw.core.checkpoint) ------------------------------------------------------
    def __getstate__(self) -> dict[str, object]:
        """Everything but what belongs to the process around the core: where it emits, the
        driver's counters (a resumed process attaches its own) and the ground's record taps."""
        state: dict[str, object] = {name: getattr(self, name) for name in self.__slots__ if name != "record_taps"}
        state["_sink"] = None
        state["extra_counters"] = None
        if self._warm_kinds is not None:
            state["_warm_kinds"] = set()  # a resumed process starts cold: it warms up again
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.record_taps = ()
        for name, value in state.items():
            setattr(self, name, value)

    def attach(self, emit: Emit) -> None:
        """Emit through ``emit`` from now on (a core restored from a checkpoint)."""
        self._sink = emit

    @property
    def detector(self) -> AnomalyDetector | None:
        return None if self.reporter is None else self.reporter.detector

    @property
    def finished(self) -> bool:
        return self._end is not None

    @property
    def t_last(self) -> float:
        """Epoch of the newest measurement handled (the initial epoch before any)."""
        return self._last_t

    # -- lifecycle -----------------------------------------------------------------------------
    def start(self) -> None:
        """The start-of-run status."""
        self._emit_status("start", self.t0)

    def finish(self) -> m.RunStatus:
        """End of stream; returns the end-of-run status it emitted (again, if called again).

        In order: release the measurements the intake still holds, drain the executive's backlog
        (each frame's budget report after it), let every gating network close what it held back
        (e.g. a partial batch) and the detector judge it, the estimates and the anomaly report at
        the last epoch, then the end-of-run RunStatus. Its counts are the core's counters, the
        driver's ``extra_counters``, and the number of messages emitted per topic before it (keys
        with '/'), which the ground logger checks its recording against."""
        if self._end is not None:
            return self._end
        for meas in self.guard.flush():
            self._queue(meas)
        while self.executive.pending_jobs:
            with no_gc_pauses():
                drained = self.executive.drain(max_frames=1)
            for rep in drained.reports:
                self._emit_budget(rep)
                self._emit_residuals(rep.t_s, force=False)
        t_end = max(self._last_t, self.bank.t)
        for name, net in self.networks.items():
            upd = net.flush()
            if upd is not None:
                # outside any frame: a declaration here is known at its data epoch
                self._publish_weights(name, upd, frame_end=None)
        self._emit_residuals(t_end, force=True)
        self._emit_estimates(t_end)
        if self.reporter is not None:
            self._report_anomaly(self.reporter.state, force=True, t=t_end)
        self._last_t = t_end
        counts = self.status_counts()
        counts.update(self.counters.emitted)
        self._end = status_message(t_end, self.run_id, "end-of-run", counts)
        self._emit(topics.FSW_STATUS, self._end)
        return self._end

    # -- intake --------------------------------------------------------------------------------
    def ingest_payload(self, payload: bytes | str) -> None:
        """A raw ICD payload from the transport: decoded strictly, counted if malformed."""
        self.ingest_payloads((payload,))

    def ingest_payloads(self, payloads: Sequence[bytes | str]) -> None:
        """Raw payloads taken together, as :meth:`ingest_payload` of each in turn — the same
        state and outputs — but all decoded first, back to back: between two measurements'
        worth of the core's work the decoder ran with cold caches (6.5 against 2.4 µs a
        measurement). A malformed one is counted where it stands."""
        decoded: list[m.Measurement | None] = []
        for payload in payloads:
            try:
                decoded.append(codec.from_json(m.Measurement, payload))
            except codec.ICDError:
                decoded.append(None)
        for meas in decoded:
            if meas is None:
                self.taken += 1
                self.counters.decode_errors += 1
            else:
                self.ingest(meas)

    def ingest(self, meas: m.Measurement) -> None:
        """Accept one measurement (any order; see :class:`fsw.ingest.SequenceGuard`)."""
        self.taken += 1
        for released in self.guard.push(meas):
            self._queue(released)

    def _queue(self, meas: m.Measurement) -> None:
        self.advance_to(meas.t_s)
        if self._warm_kinds is not None and meas.kind not in self._warm_kinds:
            self._warm_up(meas)
        self.executive.submit(Job(meas.t_s, self._stages_now(), str(meas.seq), JobContext(meas)))
        if self.rqp.enabled or self.rqp.busy:
            # one slice of the search per measurement, lowest priority, its own lane: never ahead
            # of the bank, charged to the frame that runs it
            self.executive.submit(Job(meas.t_s, (Stage("telemetry", self._stage_rqp, lane="rqp",
                                                       cost=self.config.rqp.slice_cost, name="rqp"),), "rqp"))

    def _stages_now(self) -> tuple[Stage, ...]:
        """The pipeline's stages for the load of now (enabled filters, networks, adaptive LP work)."""
        # asked per measurement: the enabled mask's bytes are a cheaper key than its count
        active = self.bank.active
        key = (active.tobytes(), len(self.networks), self.bank.adaptive_lp_cost())
        stages = self._stages.get(key)
        if stages is None:
            load = Load(active_filters=int(np.count_nonzero(active)), networks=key[1], adaptive_lp=key[2])
            stages = self._stages[key] = build_stages(self, self.PIPELINE, self.config.budget, load)
        return stages

    def _warm_up(self, meas: m.Measurement) -> None:
        """Fly ``meas``'s job once on a throwaway copy of the core, before any frame runs it.

        The first measurement of a kind pays one-time costs — code loaded, tables built, caches
        filled, compiled kernels loaded — of ten to twenty typical stages; charged to the frame
        that first runs it, that overran the budget at start-up. They belong to the start-up
        phase, not to the flight budget: the copy pays them here, outside every frame. It shares
        nothing with the core that the job's outcome depends on, so the core's outputs are
        those of a core without warm-up (``tests/test_fsw_warm_up.py``); what carries over is
        what the process keeps — loaded code and kernels, the caches of pure functions — and
        the environment's tables when the job is next in line. A warm-up that fails is ignored."""
        self._warm_kinds.add(meas.kind)  # type: ignore[union-attr]
        # With nothing queued, the next calls the core makes on its environment are this job's,
        # the very calls the copy makes: sharing the environment then leaves it as the job
        # itself would (the ephemeris table built where the job would build it), and the job
        # finds it ready. With jobs queued, their calls come first: the copy gets its own. The
        # Earth-orbit bank has no ephemeris environment to share.
        stack = getattr(self.bank, "stack", None)
        env = getattr(stack, "env", None)
        share = env is not None and self.executive.pending_jobs == 0
        clone = copy.deepcopy(self, {id(env): env} if share else None)
        clone._sink = lambda topic, msg: None
        clone.record_taps = ()
        clone._warm_kinds = None
        job = Job(meas.t_s, clone._stages_now(), str(meas.seq), JobContext(meas))
        for stage in job.stages:
            try:
                stage.fn(job.context)
            except Exception:  # the copy is thrown away whatever it did
                pass

    def advance_to(self, t: float) -> None:
        """Run every frame that ends before ``t``.

        A BudgetReport is emitted for every frame that did or deferred work, and for idle frames
        at most once per ``telemetry.idle_budget_every_s`` (tracking gaps are days long; a report
        per idle frame would bury the interesting ones)."""
        executive, frame_s = self.executive, self.config.budget.frame_s
        if executive.t_frame_end + frame_s > t:
            return
        # The garbage collector stays out of the frames (see no_gc_pauses): it may run after
        # them, outside any stage's CPU accounting.
        gc_was_enabled = gc.isenabled()
        gc.disable()
        try:
            while True:
                # Idle frames that would report nothing are passed in one step; the first frame
                # that is due a report (or has work) runs normally.
                reports_from = self._next_idle_report
                if self._residuals and self.config.telemetry.residuals_every_s is not None:
                    reports_from = min(reports_from, self._next_residuals)
                executive.skip_idle(t, before=reports_from)
                if executive.t_frame_end + frame_s > t:
                    break
                rep = executive.run_frame()
                busy = rep.processed or rep.deferred or rep.backlog or rep.overruns != self._last_overruns
                if busy or rep.t_s >= self._next_idle_report:
                    self._emit_budget(rep)
                self._emit_residuals(rep.t_s, force=False)
                if executive.t_frame_end + frame_s > t:
                    break
        finally:
            if gc_was_enabled:
                gc.enable()

    # -- the pipeline: the stages of one measurement's job, in order -----------------------------
    def _stage_ingest(self, ctx: JobContext) -> None:
        """The intake's bookkeeping ran on arrival (sequence guard); this stage charges its cost
        to the frame that takes the measurement on."""

    def _stage_bank(self, ctx: JobContext) -> None:
        # Estimates go out on a fixed grid t0 + k·estimate_every_s (so the ground can compare
        # them with truth at exactly the same epochs): propagate to each grid epoch passed.
        while self._next_estimate <= ctx.meas.t_s:
            if self._next_estimate >= self.bank.t:
                self.bank.propagate_to(self._next_estimate)
                self._emit_estimates(self._next_estimate)
            self._next_estimate += self.config.telemetry.estimate_every_s
        if self.rqp.enabled:
            self.rqp.before(self.bank)
        try:
            ctx.record = self.bank.process(ctx.meas)
        except MeasurementRejected as exc:
            self.counters.bank_rejected[exc.reason] += 1
            return
        for tap in self.record_taps:
            tap(ctx.record)
        if self.config.telemetry.residuals_every_s is not None:
            self._residuals.append((ctx.record, ctx.meas.source))
        if self.rqp.enabled:
            self.rqp.after(self.bank, ctx.meas, self._preferred_filter())

    def _stage_gating(self, ctx: JobContext) -> None:
        if ctx.record is None:
            return
        try:
            # one check of the record serves every network (each would refuse it alike)
            mask = check_record(ctx.record, self.filters)
        except GatingError:
            for net in self.networks.values():
                net.refuse()
            self.counters.gating_errors += len(self.networks)
            return
        for name, net in self.networks.items():
            try:
                upd = net.update_checked(ctx.record, mask)
            except GatingError:
                self.counters.gating_errors += 1
                continue
            if upd is not None:
                # what this stage concludes is known at the end of the frame running it: later
                # than the data if the budget made the gating lag behind the filters
                self._publish_weights(name, upd, frame_end=self.executive.t_now)

    def _stage_telemetry(self, ctx: JobContext) -> None:
        t = ctx.meas.t_s
        self._last_t = max(self._last_t, t)
        tel = self.config.telemetry
        if self.reporter is not None and t >= self._next_anomaly:
            self._report_anomaly(self.reporter.state, force=True, t=t)
            while self._next_anomaly <= t:
                self._next_anomaly += tel.anomaly_every_s
        if t >= self._next_status:
            self._emit_status("running", t)
            while self._next_status <= t:
                self._next_status += tel.status_every_s

    def _stage_rqp(self) -> None:
        done = self.rqp.slice(self.bank, self.executive.t_now)
        if done is not None:
            self._emit(topics.FSW_RQP, report_message(done))

    def _preferred_filter(self) -> str:
        """The enabled filter of largest weight (the detector's network), or the best-informed
        one before any weights."""
        weights = self.weights_for_combination()
        enabled = [n for n, a in zip(self.filters, self.bank.active) if a]
        if weights is None:
            return min(enabled, key=self.bank.position_sigma_km)
        w = dict(zip(self.filters, weights))
        return max(enabled, key=lambda n: w.get(n, 0.0))

    #: One job per measurement: (priority class, label, stage, declared cost in work units).
    PIPELINE: ClassVar[tuple[StageSpec[FswCore], ...]] = (
        StageSpec("ingest", None, _stage_ingest, ingest_cost),
        StageSpec("primary", BANK_STAGE, _stage_bank, bank_cost),
        StageSpec("gating", None, _stage_gating, gating_cost),
        StageSpec("telemetry", None, _stage_telemetry, telemetry_cost),
    )

    # -- telemetry -----------------------------------------------------------------------------
    def _emit(self, topic: str, msg: FswMessage) -> None:
        self._sink(topic, msg)
        self.counters.emitted[topic] += 1

    def _publish_weights(self, name: str, upd: WeightsUpdate, frame_end: float | None) -> None:
        """New weights of network ``name``: out to the ground, and to the detector if it watches it."""
        self.latest[name] = upd
        topic = self._weights_topics.get(upd.network)
        if topic is None:
            topic = self._weights_topics[upd.network] = f"{topics.FSW_WEIGHTS}/{upd.network}"
        self._emit(topic, weights_message(upd))
        if self.reporter is not None and name == self.config.detector.network:
            state = self.reporter.consume(upd, frame_end, active=self.bank.active.copy())
            self._report_anomaly(state, force=False)

    def _report_anomaly(self, state: AnomalyState, force: bool, t: float | None = None) -> None:
        """Report ``state`` if it is news (flag, class or declaration changed) or ``force``."""
        if self.reporter is None:
            return
        if self.reporter.news(state) or force:
            self._emit(topics.FSW_ANOMALY, self.reporter.report(state, self._last_t if t is None else t))

    def reset_detector(self) -> None:
        """Telecommanded reset of the detector; the ground hears of it at once."""
        if self.reporter is not None:
            self._report_anomaly(self.reporter.reset(), force=True)

    def weights_for_combination(self) -> np.ndarray | None:
        net = self.config.detector.network
        upd = self.latest.get(net) or next(iter(self.latest.values()), None)
        return None if upd is None else np.asarray(upd.weights, dtype=float)

    def _best_filter(self, ests: dict[str, FilterEstimate], weights: np.ndarray | None) -> str:
        """The filter to navigate on. While no anomaly is declared the gating weights of a
        healthy bank are all ≈ 1/N (Lubey & Ely 2022 §4.2: "we would usually select the default
        filter") and say nothing about accuracy, so the best-informed enabled filter (smallest
        RTPC) is used; once an anomaly is declared, the filter the gating network prefers."""
        enabled = [n for n, a in zip(self.filters, self.bank.active) if a]
        flagged = self.reporter is not None and self.reporter.state.flag
        if flagged and weights is not None:
            w = dict(zip(self.filters, weights))
            return max(enabled, key=lambda n: w.get(n, 0.0))
        return min(enabled, key=lambda n: ests[n].position_sigma_km)

    def _emit_estimates(self, t: float) -> None:
        weights = self.weights_for_combination()
        ests = self.bank.estimates(weights)
        if "best" in ests:
            ests["best"] = ests[self._best_filter(ests, weights)]
        tel = self.config.telemetry
        # "best" is one of the filters' own estimates: its message is that filter's, relabelled
        made: dict[int, m.Estimate] = {}
        for label, est in ests.items():
            if label in self.filters and not tel.per_filter_estimates:
                continue
            same = made.get(id(est))
            if same is None:
                msg = made[id(est)] = estimate_message(est, label, tel.full_covariance)
            else:
                msg = dataclasses.replace(same, filter=label)
            self._emit(f"{topics.FSW_ESTIMATE}/{label}", msg)
        self._emit_bplanes(t, {k: v for k, v in ests.items() if k not in self.filters or tel.per_filter_estimates})

    def _emit_residuals(self, t: float, force: bool) -> None:
        """The residuals gathered since the last message, at the end of a frame once
        ``telemetry.residuals_every_s`` has passed (``force``: at the end of the run)."""
        every = self.config.telemetry.residuals_every_s
        if every is None or not self._residuals or not (force or t >= self._next_residuals):
            return
        samples = residual_samples(self._residuals)
        for start in range(0, len(samples), m.MAX_COUNTERS):
            self._emit(topics.FSW_RESIDUALS, residuals_message(t, self.filters, samples[start:start + m.MAX_COUNTERS]))
        self._residuals = []
        while self._next_residuals <= t:
            self._next_residuals += max(every, self.config.budget.frame_s)

    def _emit_bplanes(self, t: float, ests: dict[str, FilterEstimate]) -> None:
        """B-plane targeting of the estimates just emitted, every ``telemetry.bplane_every_s``."""
        every = self.config.telemetry.bplane_every_s
        if every is None or t < self._next_bplane:
            return
        while self._next_bplane <= t:
            self._next_bplane += every
        # "best" is one of the filters' own estimates: its targeting is that filter's, relabelled
        done: dict[int, m.BPlane | None] = {}
        for label, est in ests.items():
            if id(est) in done:
                same = done[id(est)]
                msg = None if same is None else dataclasses.replace(same, filter=label)
            else:
                msg = done[id(est)] = bplane_message(est, label)
            if msg is not None:
                self._emit(f"{topics.FSW_BPLANE}/{label}", msg)

    def _emit_budget(self, rep: BudgetReportData) -> None:
        self._last_overruns = rep.overruns
        self.frames_reported += 1
        self.max_utilisation = max(self.max_utilisation, float(rep.utilisation))
        self._next_idle_report = rep.t_s + self.config.telemetry.idle_budget_every_s
        self._emit(topics.FSW_BUDGET, budget_message(rep))

    def unprocessed(self) -> int:
        """Measurements taken that have not been through the filter bank yet: queued before their
        bank stage, or held by the intake. (A job whose bank stage has run is processed or
        rejected, whatever of its gating and telemetry still waits.)"""
        return self.executive.pending_with(BANK_STAGE) + self.guard.pending

    def status_counts(self) -> dict[str, int]:
        """The counters every RunStatus carries (see :func:`fsw.core.counters.status_counts`)."""
        return status_counts(self.counters, self.guard, self.bank, self.executive, self.extra_counters)

    def _emit_status(self, state: RunState, t: float) -> None:
        self._emit(topics.FSW_STATUS, status_message(t, self.run_id, state, self.status_counts()))

    def stopped(self, reason: str) -> m.RunStatus:
        """Stopped before the end of the stream (a stop request): the status that says so, with
        the counters as they stand — measurements taken but not yet processed show in
        ``pending`` and ``backlog`` — emitted and returned. Nothing is drained: a stop request
        asks for an end now, not after the backlog."""
        msg = status_message(self._last_t, self.run_id, "error", self.status_counts(), message=reason)
        self._emit(topics.FSW_STATUS, msg)
        return msg

    # -- telecommands --------------------------------------------------------------------------
    def command(self, tc: m.Telecommand) -> m.TelecommandReply:
        """Carry out a telecommand (see :mod:`fsw.core.commands`); anything that cannot be done
        is an error reply and changes nothing. Either way the command and its reply are
        published as a :class:`~fsw.interface.messages.CommandRecord`."""
        reply = commands.execute(self, tc)
        self._emit(topics.FSW_COMMANDS, command_record(self._last_t, self.taken, tc, reply, ended=self.finished))
        return reply

    def command_payload(self, payload: bytes | str) -> m.TelecommandReply:
        """A raw telecommand payload: malformed ones get an error reply and are counted."""
        try:
            tc = codec.from_json(m.Telecommand, payload)
        except codec.ICDError as exc:
            reply = m.TelecommandReply(id="", ok=False, error=f"malformed telecommand: {exc}"[:500])
            self.record_malformed_command(payload, reply)
            return reply
        return self.command(tc)

    def record_refused_command(self, tc: m.Telecommand | None, payload: bytes | str, reply: m.TelecommandReply,
                               reason: str) -> None:
        """Publish the record of a telecommand the transport refused before the core saw it (its
        authentication failed): it changed nothing, and the transport counts it."""
        self._emit(topics.FSW_COMMANDS, command_record(self._last_t, self.taken, tc, reply, payload, self.finished,
                                                       refused=reason))

    def record_malformed_command(self, payload: bytes | str, reply: m.TelecommandReply) -> None:
        """Count a telecommand payload that did not decode and publish its record (it changed
        nothing; a transport that answers such payloads itself reports them here)."""
        self.counters.commands_malformed += 1
        self._emit(topics.FSW_COMMANDS, command_record(self._last_t, self.taken, None, reply, payload, self.finished))

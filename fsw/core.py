"""The flight software's core: bank, gating networks and anomaly detector under the executive.

``FswCore`` is transport-free and deterministic in work-unit budget mode: the FSW process feeds it
measurements from Zenoh and publishes what it emits, the in-process runner and the replay
re-run feed it from memory or from an MCAP file. All three therefore run the same code.

Time is driven by the data: before a measurement tagged t is queued, every frame ending before t
runs (so a gap in tracking gives the executive idle frames to catch up its backlog). Each
measurement becomes one executive job with four ordered stages:

``ingest``   bookkeeping (cheap);
``primary``  the filter bank — all filters are advanced in one vectorised stage, because they
             share the propagation of the union state and per-filter stages would cost more than
             the whole bank; its work-unit cost scales with the number of filters;
``gating``   every gating network, then the detector on the configured network's new weights;
``telemetry`` estimates, anomaly reports and status at their configured cadences.

Nothing is dropped: a measurement the bank rejects is counted by reason and its gating stage
skipped; a stage that raises is contained and counted by the executive.
"""

from __future__ import annotations

import gc
import time
from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Callable

import numpy as np

from fsw.astro.time import tdb_to_unix
from fsw.config import FswConfig, InitialState
from fsw.executive import FrameExecutive, Job, Stage
from fsw.fdir.detector import AnomalyDetector, AnomalyState
from fsw.filters.bank import FilterBank, FilterEstimate
from fsw.filters.errors import MeasurementRejected, UnknownFilter
from fsw.gating.base import GatingError, GatingNetwork, WeightsUpdate
from fsw.gating.registry import make_network
from fsw.ingest import SequenceGuard
from fsw.interface import codec, messages as m, topics

Emit = Callable[[str, Any], None]


class CommandRejected(ValueError):
    """A telecommand that is well-formed but cannot be carried out (unknown filter, bad value)."""


@contextmanager
def _no_gc_pauses():
    """Keep Python's cyclic garbage collector out of the frames.

    A full collection costs tens of ms — longer than any stage — and would land on whatever stage
    happens to allocate at that moment, charging it a spurious overrun. Collection is deferred
    to just after the frame, outside any stage's CPU accounting (a flight executive likewise
    keeps memory management out of its time-critical frames)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


@lru_cache(maxsize=4096)
def _unix_offset(hour: int) -> float:
    t = hour * 3600.0
    return float(tdb_to_unix(t)) - t


def stamp(t_s: float) -> m.Stamp:
    """Foxglove-style stamp of a TDB epoch.

    Within an hour UTC − TDB changes only through the ≤ 1.7 ms periodic TDB − TT term (< 2 µs
    per hour) — and through a leap second, if one falls in that hour (stamps after it are then
    1 s off until the next hour). One exact conversion per hour is plenty for a display
    timestamp and makes telemetry cheap to stamp."""
    return m.Stamp.from_unix(t_s + _unix_offset(int(t_s // 3600.0)))


@dataclass
class _JobContext:
    meas: m.Measurement
    record: Any = None


@dataclass
class CoreCounters:
    decode_errors: int = 0
    bank_rejected: Counter = field(default_factory=Counter)
    gating_errors: int = 0
    commands_ok: int = 0
    commands_rejected: int = 0


class FswCore:
    """Bank + gating + detector + executive; emits ICD telemetry through ``emit(topic, msg)``."""

    def __init__(self, config: FswConfig, emit: Emit, *, run_id: str = "run", clock: Callable[[], float] = time.thread_time):
        if config.initial_state is None:
            raise ValueError("the FSW needs an a-priori initial state (fsw.initial_state)")
        self.config = config
        self.run_id = run_id
        self._emit = emit
        init: InitialState = config.initial_state
        self.bank = FilterBank(config.bank, init.t_s, init.position_km, init.velocity_km_s)
        self.filters = tuple(self.bank.names)
        self.networks: dict[str, GatingNetwork] = {
            g.network: make_network(g.network, self.filters, g.params) for g in config.gating
        }
        self.latest: dict[str, WeightsUpdate] = {}
        det = config.detector
        self.detector: AnomalyDetector | None = None
        if det.calibration is not None:
            self.detector = AnomalyDetector(det.calibration, config.families())
        self.guard = SequenceGuard(window=config.reorder_window)
        self.counters = CoreCounters()
        # a stage that raises is contained and counted by the executive (BudgetReport.errors)
        self.executive = FrameExecutive(config.budget, clock=clock, t0=init.t_s)
        self.t0 = init.t_s
        self._next_estimate = init.t_s
        self._next_anomaly = init.t_s
        self._next_status = init.t_s + config.telemetry.status_every_s
        self._last_anomaly: tuple | None = None
        self._declared_at: float | None = None
        self._last_t = init.t_s
        self.finished = False
        #: counters of the process around the core (e.g. malformed telecommands), in status replies
        self.extra_counters: Callable[[], dict[str, int]] | None = None
        self._last_overruns = 0
        self._next_idle_report = init.t_s
        self.frames_reported = 0
        self.max_utilisation = 0.0

    # -- intake --------------------------------------------------------------------------------
    def ingest_payload(self, payload: bytes | str) -> None:
        """A raw ICD payload from the transport: decoded strictly, counted if malformed."""
        try:
            meas = codec.from_json(m.Measurement, payload)
        except codec.ICDError:
            self.counters.decode_errors += 1
            return
        self.ingest(meas)

    def ingest(self, meas: m.Measurement) -> None:
        """Accept one measurement (any order; see :class:`fsw.ingest.SequenceGuard`)."""
        for released in self.guard.push(meas):
            self._queue(released)

    def _queue(self, meas: m.Measurement) -> None:
        self.advance_to(meas.t_s)
        ctx = _JobContext(meas)
        cfg = self.config.budget
        n_active = int(self.bank.active.sum())
        bank_cost = cfg.primary_cost + cfg.filters_cost * max(n_active - 1, 0)
        stages = (
            Stage("ingest", lambda: None, cost=cfg.ingest_cost),
            Stage("primary", lambda: self._run_bank(ctx), cost=bank_cost, name="bank"),
            Stage("gating", lambda: self._run_gating(ctx), cost=cfg.gating_cost * max(len(self.networks), 1)),
            Stage("telemetry", lambda: self._run_telemetry(ctx), cost=cfg.telemetry_cost),
        )
        self.executive.submit(Job(t=meas.t_s, stages=stages, tag=str(meas.seq)))

    def advance_to(self, t: float) -> None:
        """Run every frame that ends before ``t``.

        A BudgetReport is emitted for every frame that did or deferred work, and for idle frames
        at most once per ``telemetry.idle_budget_every_s`` (tracking gaps are days long; a report
        per idle frame would bury the interesting ones)."""
        while self.executive.t_frame_end + self.config.budget.frame_s <= t:
            with _no_gc_pauses():
                rep = self.executive.run_frame()
            busy = rep.processed or rep.deferred or rep.backlog or rep.overruns != self._last_overruns
            if busy or rep.t_s >= self._next_idle_report:
                self._emit_budget(rep)

    # -- stages --------------------------------------------------------------------------------
    def _run_bank(self, ctx: _JobContext) -> None:
        # Estimates go out on a fixed grid t0 + k·estimate_every_s (so the ground can compare
        # them with truth at exactly the same epochs): propagate to each grid epoch passed.
        while self._next_estimate <= ctx.meas.t_s:
            if self._next_estimate >= self.bank.t:
                self.bank.propagate_to(self._next_estimate)
                self._emit_estimates(self._next_estimate)
            self._next_estimate += self.config.telemetry.estimate_every_s
        try:
            ctx.record = self.bank.process(ctx.meas)
        except MeasurementRejected as exc:
            self.counters.bank_rejected[getattr(exc, "reason", "invalid")] += 1

    def _run_gating(self, ctx: _JobContext) -> None:
        rec = ctx.record
        if rec is None:
            return
        for name, net in self.networks.items():
            try:
                upd = net.update(rec)
            except GatingError:
                self.counters.gating_errors += 1
                continue
            if upd is None:
                continue
            self.latest[name] = upd
            self._emit_weights(upd)
            if self.detector is not None and name == self.config.detector.network:
                was_flagged = self.detector.state.flag
                state = self.detector.consume(upd, active=self.bank.active.copy())
                if state.flag and not was_flagged:
                    # declared when this stage ran: later than the data if the budget made
                    # the gating lag behind the filters
                    self._declared_at = max(float(state.declared_t or upd.t), self.executive.t_now)
                self._maybe_emit_anomaly(state, force=False)

    def _run_telemetry(self, ctx: _JobContext) -> None:
        t = ctx.meas.t_s
        self._last_t = max(self._last_t, t)
        tel = self.config.telemetry
        if self.detector is not None and t >= self._next_anomaly:
            self._maybe_emit_anomaly(self.detector.state, force=True, t=t)
            while self._next_anomaly <= t:
                self._next_anomaly += tel.anomaly_every_s
        if t >= self._next_status:
            self._emit_status("running", t)
            while self._next_status <= t:
                self._next_status += tel.status_every_s

    # -- telemetry -----------------------------------------------------------------------------
    def _emit_weights(self, upd: WeightsUpdate) -> None:
        groups = upd.groups() if hasattr(upd, "groups") else {}
        stat = tuple(float(s) for s in upd.statistic) if getattr(upd, "statistic", None) is not None else ()
        msg = m.FilterWeights(
            t_s=float(upd.t), timestamp=stamp(upd.t), network=upd.network, batch=int(upd.batch),
            filters=tuple(upd.filters), weights=tuple(float(w) for w in upd.weights),
            groups={k: float(v) for k, v in groups.items()}, statistic=stat,
        )
        self._emit(f"{topics.FSW_WEIGHTS}/{upd.network}", msg)

    def anomaly_message(self, state: AnomalyState, t: float | None = None) -> m.AnomalyReport:
        t_s = float(state.t if state.t is not None else (t if t is not None else self._last_t))
        return m.AnomalyReport(
            t_s=t_s, timestamp=stamp(t_s), flag=bool(state.flag), anomaly_class=state.anomaly_class,
            confidence=float(min(max(state.confidence, 0.0), 1.0)),
            onset_s=None if state.onset_t is None else float(state.onset_t),
            declared_s=None if state.declared_t is None else max(float(state.declared_t), self._declared_at or 0.0),
            network=state.network, statistic=float(state.statistic or 0.0), threshold=float(state.threshold),
            evidence={k: float(v) for k, v in state.evidence.items()},
        )

    def _maybe_emit_anomaly(self, state: AnomalyState, force: bool, t: float | None = None) -> None:
        key = (state.flag, state.anomaly_class, state.declared_t)
        if force or key != self._last_anomaly:
            self._last_anomaly = key
            self._emit(topics.FSW_ANOMALY, self.anomaly_message(state, t))

    def _estimate_message(self, est: FilterEstimate, label: str) -> m.Estimate:
        full = self.config.telemetry.full_covariance
        return m.Estimate(
            t_s=float(est.t), timestamp=stamp(est.t), filter=label,
            position_km=tuple(float(v) for v in est.position_km),
            velocity_km_s=tuple(float(v) for v in est.velocity_km_s),
            position_sigma_km=float(est.position_sigma_km), state_names=tuple(est.state_names),
            state=tuple(float(v) for v in est.x), sigma=tuple(float(v) for v in est.sigma),
            covariance=tuple(tuple(float(v) for v in row) for row in est.P) if full else None,
        )

    def weights_for_combination(self) -> np.ndarray | None:
        net = self.config.detector.network
        upd = self.latest.get(net) or next(iter(self.latest.values()), None)
        return None if upd is None else np.asarray(upd.weights, dtype=float)

    def _best_filter(self, ests: dict[str, FilterEstimate], weights: np.ndarray | None) -> str:
        """The filter to navigate on. While no anomaly is declared the gating weights of a
        healthy bank are all ≈ 1/N (seed 001 §4.2: "we would usually select the default filter")
        and say nothing about accuracy, so the best-informed enabled filter (smallest RTPC) is
        used; once an anomaly is declared, the filter the gating network prefers."""
        enabled = [n for n, a in zip(self.filters, self.bank.active) if a]
        flagged = self.detector is not None and self.detector.state.flag
        if flagged and weights is not None:
            w = dict(zip(self.filters, weights))
            return max(enabled, key=lambda n: w.get(n, 0.0))
        return min(enabled, key=lambda n: ests[n].position_sigma_km)

    def _emit_estimates(self, t: float) -> None:
        weights = self.weights_for_combination()
        ests = self.bank.estimates(weights)
        if "best" in ests:
            ests["best"] = ests[self._best_filter(ests, weights)]
        for label, est in ests.items():
            if label in self.filters and not self.config.telemetry.per_filter_estimates:
                continue
            self._emit(f"{topics.FSW_ESTIMATE}/{label}", self._estimate_message(est, label))

    def _emit_budget(self, rep: Any) -> None:
        self._last_overruns = rep.overruns
        self.frames_reported += 1
        self.max_utilisation = max(self.max_utilisation, float(rep.utilisation))
        self._next_idle_report = rep.t_s + self.config.telemetry.idle_budget_every_s
        self._emit(topics.FSW_BUDGET, m.BudgetReport(timestamp=stamp(rep.t_s), **rep.icd_fields()))

    def status_counts(self) -> dict[str, int]:
        c = self.guard.counters.as_dict()
        c["decode_errors"] = self.counters.decode_errors
        c["bank_rejected"] = sum(self.counters.bank_rejected.values())
        for reason, n in sorted(self.counters.bank_rejected.items()):
            c[f"bank_rejected_{reason}"] = n
        c["processed"] = int(self.bank.processed_count)
        c["gating_errors"] = self.counters.gating_errors
        c["stage_errors"] = len(self.executive.errors)
        c["commands_ok"] = self.counters.commands_ok
        c["commands_rejected"] = self.counters.commands_rejected
        c["backlog"] = int(self.executive.backlog)
        c["pending"] = int(self.executive.pending_jobs)  # queued, due or not yet due
        c["rejected"] = c.get("rejected", 0) + c["decode_errors"] + c["bank_rejected"]
        if self.extra_counters is not None:
            c.update(self.extra_counters())
        return c

    def _emit_status(self, state: str, t: float, message: str = "") -> None:
        self._emit(topics.FSW_STATUS, m.RunStatus(t_s=float(t), timestamp=stamp(t), run_id=self.run_id, source="fsw",
                                                   state=state, counts=self.status_counts(), message=message))

    def start(self) -> None:
        self._emit_status("start", self.t0)

    @property
    def t_last(self) -> float:
        """Epoch of the newest measurement handled (the initial epoch before any)."""
        return self._last_t

    def end_status(self, extra_counts: dict[str, int] | None = None) -> m.RunStatus:
        """The end-of-run RunStatus (``extra_counts``: e.g. per-topic counts of a transport)."""
        counts = self.status_counts()
        counts.update(extra_counts or {})
        t = self._last_t
        return m.RunStatus(t_s=float(t), timestamp=stamp(t), run_id=self.run_id, source="fsw",
                           state="end-of-run", counts=counts)

    def finish(self, emit_end: bool = True) -> None:
        """End of stream: release waiting measurements, drain the backlog, final telemetry.

        ``emit_end=False`` leaves the end-of-run status to the caller (a transport adds its
        per-topic counts to it, see :meth:`end_status`)."""
        if self.finished:
            return
        for meas in self.guard.flush():
            self._queue(meas)
        with _no_gc_pauses():
            result = self.executive.drain()
        for rep in result.reports:
            self._emit_budget(rep)
        t_end = max(self._last_t, self.bank.t)
        for name, net in self.networks.items():
            flush = getattr(net, "flush", None)
            if flush is None:
                continue
            upd = flush()
            if upd is not None:
                self.latest[name] = upd
                self._emit_weights(upd)
                if self.detector is not None and name == self.config.detector.network:
                    self._maybe_emit_anomaly(self.detector.consume(upd, active=self.bank.active.copy()), force=False)
        self._emit_estimates(t_end)
        if self.detector is not None:
            self._maybe_emit_anomaly(self.detector.state, force=True, t=t_end)
        self._last_t = t_end
        if emit_end:
            self._emit(topics.FSW_STATUS, self.end_status())
        self.finished = True

    # -- telecommands --------------------------------------------------------------------------
    def command(self, tc: m.Telecommand) -> m.TelecommandReply:
        """Carry out a validated telecommand; anything that cannot be done is an error reply."""
        try:
            status, detail = self._command(tc)
        except (CommandRejected, GatingError, UnknownFilter, KeyError, ValueError, TypeError) as exc:
            self.counters.commands_rejected += 1
            return m.TelecommandReply(id=tc.id, ok=False, error=str(exc) or exc.__class__.__name__)
        self.counters.commands_ok += 1
        return m.TelecommandReply(id=tc.id, ok=True, status=status, detail=detail)

    def _network(self, name: str | None) -> list[GatingNetwork]:
        if name is None or name in ("", "*", "all"):
            return list(self.networks.values())
        if name not in self.networks:
            raise CommandRejected(f"unknown gating network {name!r}; running: {', '.join(self.networks)}")
        return [self.networks[name]]

    def _command(self, tc: m.Telecommand) -> tuple[dict[str, float], dict[str, str]]:
        if tc.command == "status":
            counts = {k: float(v) for k, v in self.status_counts().items()}
            counts["t_s"] = float(self._last_t)
            for name, upd in self.latest.items():
                for f, w in zip(upd.filters, upd.weights):
                    counts[f"weight.{name}.{f}"] = float(w)
            detail = {
                "filters": ",".join(self.filters),
                "enabled": ",".join(f for f, a in zip(self.filters, self.bank.active) if a),
                "networks": ",".join(self.networks),
            }
            if self.detector is not None:
                st = self.detector.state
                detail["anomaly"] = f"{st.anomaly_class}" if st.flag else "none"
            return counts, detail
        if tc.command == "reset-gating":
            for net in self._network(tc.network):
                net.reset()
            if self.detector is not None and (tc.network in (None, "", "*", "all", self.config.detector.network)):
                self._maybe_emit_anomaly(self.detector.reset(), force=True)
            return {}, {"reset": tc.network or "all"}
        if tc.command in ("enable-filter", "disable-filter"):
            enable = tc.command == "enable-filter"
            if tc.filter not in self.filters:
                raise CommandRejected(f"unknown filter {tc.filter!r}; bank: {', '.join(self.filters)}")
            if not enable and int(self.bank.active.sum()) <= 1 and self.bank.active[self.bank.index(tc.filter)]:
                raise CommandRejected("cannot disable the last enabled filter")
            self.bank.set_enabled(tc.filter, enable)
            return {}, {tc.filter: "enabled" if enable else "disabled"}
        if tc.command == "set-param":
            nets = self._network(tc.network)
            for net in nets:
                net.set_param(tc.param, tc.value)
            return {tc.param: float(tc.value)}, {"network": tc.network or "all"}
        raise CommandRejected(f"unknown command {tc.command!r}")

    def command_payload(self, payload: bytes | str) -> m.TelecommandReply:
        """A raw telecommand payload: malformed ones get an error reply and are counted."""
        try:
            tc = codec.from_json(m.Telecommand, payload)
        except codec.ICDError as exc:
            self.counters.commands_rejected += 1
            return m.TelecommandReply(id="", ok=False, error=str(exc)[:500])
        return self.command(tc)

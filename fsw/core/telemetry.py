"""What the flight software tells the ground: its ICD messages, built in one place.

Each builder turns an onboard object into its ICD message (:mod:`fsw.interface.messages`):
gating weights into ``FilterWeights``, a filter estimate into ``Estimate``, a frame of the
executive into ``BudgetReport``, counters into ``RunStatus``, the detector's state into
``AnomalyReport``. The anomaly report also carries the one rule for dating a declaration
(:class:`DeclarationClock`); :class:`AnomalyReporter` pairs it with the detector so that the
FSW core and the ground's replay of a detector (campaign monitors) report alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from fsw.astro.time import tdb_to_unix
from fsw.executive.report import BudgetReportData
from fsw.fdir.detector import AnomalyDetector, AnomalyState
from fsw.filters.bank import FilterEstimate
from fsw.filters.record import BankRecord
from fsw.gating.base import WeightsUpdate
from fsw.interface import messages as m
from fsw.interface.messages import RunState
from fsw.models.bplane import NotHyperbolic, bplane_target

#: Every message the FSW core emits.
FswMessage = (m.FilterWeights | m.AnomalyReport | m.Estimate | m.BudgetReport | m.RunStatus | m.CommandRecord
              | m.RqpReport | m.Residuals | m.BPlane)
#: Where the core's messages go: ``emit(topic, message)`` (a publisher, a list, a recorder).
Emit = Callable[[str, FswMessage], None]


#: UTC − TDB [s] (Unix seconds minus TDB seconds past J2000) at the start of each hour, by hour.
_OFFSETS: dict[int, float] = {}
#: Hours converted together on a miss: a run's telemetry walks the hours forwards, and one
#: vectorised conversion of two days costs about what two single ones do (85 against 36 µs
#: each here): a 45-day run makes 23 conversions instead of 1,081. The same bits either way
#: (numpy's and Python's float arithmetic are the same IEEE operations; checked over ±2.3 years
#: of hours in tests/test_core_telemetry.py).
_OFFSET_RUN = 48
_OFFSETS_KEPT = 4096


def _unix_offset(hour: int) -> float:
    hit = _OFFSETS.get(hour)
    if hit is None:
        if len(_OFFSETS) >= _OFFSETS_KEPT:
            _OFFSETS.clear()
        t = (hour + np.arange(_OFFSET_RUN)) * 3600.0
        for k, v in enumerate((np.asarray(tdb_to_unix(t), dtype=float) - t).tolist()):
            _OFFSETS[hour + k] = v
        hit = _OFFSETS[hour]
    return hit


def stamp(t_s: float) -> m.Stamp:
    """Foxglove-style stamp of a TDB epoch.

    Within an hour UTC − TDB changes only through the ≤ 1.7 ms periodic TDB − TT term (< 2 µs
    per hour) — and through a leap second, if one falls in that hour (stamps after it are then
    1 s off until the next hour). One exact conversion per hour is plenty for a display
    timestamp and makes telemetry cheap to stamp."""
    return m.Stamp.from_unix(t_s + _unix_offset(int(t_s // 3600.0)))


def weights_message(upd: WeightsUpdate) -> m.FilterWeights:
    """A gating network's new weights; ``statistic`` is the per-filter quantity behind them
    (e.g. the batch chi-square G_k,i of Lubey & Ely 2022 eq. 6), empty if the network has none."""
    stat = () if upd.statistic is None else tuple(np.asarray(upd.statistic, dtype=float).tolist())
    t = float(upd.t)
    # by position, in the ICD's order: a per-measurement network sends one for every measurement
    return m.FilterWeights(t, stamp(t), upd.network, int(upd.batch), tuple(upd.filters),
                           tuple(np.asarray(upd.weights, dtype=float).tolist()), upd.groups(), stat)


def estimate_message(est: FilterEstimate, label: str, full_covariance: bool) -> m.Estimate:
    """One navigation solution; the full covariance only when configured (it is N² numbers)."""
    x = np.asarray(est.x, dtype=float).tolist()  # Python floats, as float(v) of each
    return m.Estimate(
        t_s=float(est.t), timestamp=stamp(est.t), filter=label,
        position_km=tuple(x[0:3]), velocity_km_s=tuple(x[3:6]),
        position_sigma_km=float(est.position_sigma_km), state_names=tuple(est.state_names),
        state=tuple(x), sigma=tuple(np.asarray(est.sigma, dtype=float).tolist()),
        covariance=tuple(map(tuple, np.asarray(est.P, dtype=float).tolist())) if full_covariance else None,
    )


def residual_sample(rec: BankRecord, source: str) -> m.ResidualSample:
    """The pre-fit residuals the bank computed for one measurement (Lubey & Ely 2022 eq. 5), with
    σ = √diag S and the normalised residual z̄/σ per filter and component; not recomputed.

    One per measurement, of a few numbers each: built from Python floats (square roots and
    quotients are correctly rounded, so the same as numpy's)."""
    residual = np.asarray(rec.residual, dtype=float)
    n_f, n = residual.shape
    if n == 1:
        # scalar kinds (range, Doppler: most measurements): S is its own diagonal. The fields go
        # by position, in the ICD's order (one sample per measurement)
        z1 = residual.ravel().tolist()
        sig1 = [math.sqrt(max(v, 0.0)) for v in np.asarray(rec.S, dtype=float).ravel().tolist()]
        return m.ResidualSample(
            float(rec.t), int(rec.seq), rec.kind, source, tuple([(a,) for a in z1]), tuple([(s,) for s in sig1]),
            tuple([(a / s if s > 0.0 else 0.0,) for a, s in zip(z1, sig1)]),
            tuple(np.asarray(rec.chi2, dtype=float).tolist()), tuple(np.asarray(rec.processed, dtype=bool).tolist()),
        )
    z = residual.tolist()
    variances = np.asarray(rec.S, dtype=float).reshape(n_f, n * n)[:, ::n + 1].tolist()  # diag S per filter
    sigma = [[math.sqrt(max(v, 0.0)) for v in row] for row in variances]
    norm = [tuple([a / s if s > 0.0 else 0.0 for a, s in zip(z_i, s_i)]) for z_i, s_i in zip(z, sigma)]
    return m.ResidualSample(
        t_s=float(rec.t), seq=int(rec.seq), kind=rec.kind, source=source, residual=tuple(map(tuple, z)),
        sigma=tuple(map(tuple, sigma)), normalised=tuple(norm), nis=tuple(np.asarray(rec.chi2, dtype=float).tolist()),
        processed=tuple(np.asarray(rec.processed, dtype=bool).tolist()),
    )


def residual_samples(pending: list[tuple[BankRecord, str]]) -> list[m.ResidualSample]:
    """:func:`residual_sample` of each (record, source), in order.

    The core keeps a frame's records and makes their samples when the Residuals message goes out,
    one after the other. Made per measurement inside the bank stage, between the filters' code
    and the gating's, they took 8.4 µs of CPU per measurement in the default 45-day run; made
    together, 5.5 µs (4.2 µs each in a loop of its own). One array operation over all the
    records of a message instead of a few per record was slower still (~7 records a message)."""
    return [residual_sample(rec, source) for rec, source in pending]


def residuals_message(t: float, filters: tuple[str, ...], samples: list[m.ResidualSample]) -> m.Residuals:
    """The residuals of the measurements filtered since the last message, sent at frame end ``t``."""
    return m.Residuals(t_s=float(t), timestamp=stamp(t), filters=filters, samples=tuple(samples))


def bplane_message(est: FilterEstimate, label: str) -> m.BPlane | None:
    """B-plane targeting of one estimate (:mod:`fsw.models.bplane`); None while the estimate is
    not on a hyperbola about Mars (it then has no B-plane)."""
    try:
        tgt = bplane_target(float(est.t), est.position_km, est.velocity_km_s, est.P)
    except NotHyperbolic:
        return None
    cov = tgt.covariance_km2
    return m.BPlane(
        t_s=float(est.t), timestamp=stamp(est.t), filter=label, b_dot_r_km=tgt.b_dot_r_km, b_dot_t_km=tgt.b_dot_t_km,
        covariance_km2=((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1]))),
        periapsis_s=tgt.periapsis_s, periapsis_sigma_s=tgt.periapsis_sigma_s, v_inf_km_s=tgt.v_inf_km_s,
    )


def budget_message(rep: BudgetReportData) -> m.BudgetReport:
    """One frame of the executive (the ICD's fields, :data:`fsw.executive.report.ICD_FIELDS`, and the
    stamp: by position, in the ICD's order, because this runs for almost every frame;
    tests/test_core_telemetry.py holds it to the message built by name)."""
    return m.BudgetReport(rep.frame, rep.t_s, stamp(rep.t_s), rep.mode, rep.used, rep.budget, rep.utilisation,
                          rep.processed, rep.deferred, rep.backlog, rep.overruns, rep.errors)


def status_message(t: float, run_id: str, state: RunState, counts: Mapping[str, int],
                   message: str = "") -> m.RunStatus:
    """The FSW's lifecycle status with its counters."""
    return m.RunStatus(t_s=float(t), timestamp=stamp(t), run_id=run_id, source="fsw", state=state,
                       counts=dict(counts), message=message)


@dataclass
class DeclarationClock:
    """When the flight software knows that it has declared an anomaly.

    The detector dates a declaration by the batch that raised the flag (``declared_t``). Onboard,
    the gating stage that produced that batch runs in a frame of the executive, possibly frames
    after the data when the budget made the gating lag behind the filters; what it concludes is
    known at the end of that frame. A declaration made outside any frame (the batch a network
    closes at the end of the run) is known at its data epoch. The report's ``declared_s`` is the
    later of the two, held for as long as the flag stays raised.
    """

    declared_at: float | None = None

    def observe(self, was_flagged: bool, state: AnomalyState, frame_end: float | None) -> None:
        """Record the detector's new ``state``; ``frame_end``: end of the frame whose stage made
        it, None outside the frames."""
        if state.flag and not was_flagged and state.declared_t is not None:
            data_t = float(state.declared_t)
            self.declared_at = data_t if frame_end is None else max(data_t, frame_end)

    def declared_s(self, state: AnomalyState) -> float | None:
        """``AnomalyReport.declared_s`` of ``state`` (None while nothing is declared)."""
        if state.declared_t is None:
            return None
        return max(float(state.declared_t), self.declared_at or 0.0)


def command_record(t: float, taken: int, tc: m.Telecommand | None, reply: m.TelecommandReply,
                   payload: bytes | str = b"", ended: bool = False, refused: str = "") -> m.CommandRecord:
    """The record of one served telecommand; ``payload`` (kept only when ``tc`` is None: it did
    not decode) is stored as text, truncated to what the ICD allows. ``refused`` says why a
    command was refused unexecuted (its authentication)."""
    text = ""
    if tc is None:
        raw = payload if isinstance(payload, str) else bytes(payload).decode("utf-8", "replace")
        text = raw[: m.TEXT_CHARS]
    return m.CommandRecord(t_s=float(t), timestamp=stamp(t), taken=int(taken), telecommand=tc, reply=reply, payload=text,
                           ended=ended, refused=refused[: m.TEXT_CHARS])


def anomaly_message(state: AnomalyState, t: float, clock: DeclarationClock) -> m.AnomalyReport:
    """The ICD report of a detector ``state``; ``t`` dates a state that has no epoch of its own
    (before the first batch, after a reset)."""
    t_s = float(state.t if state.t is not None else t)
    return m.AnomalyReport(
        t_s=t_s, timestamp=stamp(t_s), flag=bool(state.flag), anomaly_class=state.anomaly_class,
        confidence=float(min(max(state.confidence, 0.0), 1.0)),
        onset_s=None if state.onset_t is None else float(state.onset_t),
        declared_s=clock.declared_s(state),
        network=state.network, statistic=float(state.statistic or 0.0), threshold=float(state.threshold),
        evidence={k: float(v) for k, v in state.evidence.items()},
    )


class AnomalyReporter:
    """An anomaly detector on one gating network and the reports it gives of itself.

    The FSW core feeds it the network's weight updates as they are produced; the ground feeds a
    fresh one the network's recorded ``FilterWeights`` (:meth:`consume_weights`). Both get the
    same states, the same declaration dating and the same ``AnomalyReport`` messages.
    """

    def __init__(self, detector: AnomalyDetector):
        self.detector = detector
        self.clock = DeclarationClock()
        self._last_reported: tuple[bool, str, float | None] | None = None

    @property
    def network(self) -> str:
        return self.detector.config.network

    @property
    def state(self) -> AnomalyState:
        return self.detector.state

    def consume(self, upd: WeightsUpdate, frame_end: float | None,
                active: np.ndarray | None = None) -> AnomalyState:
        """One weight update of the network (``frame_end``: see :meth:`DeclarationClock.observe`)."""
        was_flagged = self.detector.state.flag
        state = self.detector.consume(upd, active=active)
        self.clock.observe(was_flagged, state, frame_end)
        return state

    def consume_weights(self, msg: m.FilterWeights, frame_end: float | None) -> AnomalyState:
        """One recorded ``FilterWeights`` of the network, as :meth:`consume` (all filters active)."""
        was_flagged = self.detector.state.flag
        state = self.detector.update(msg.t_s, msg.weights, msg.filters,
                                     batch_statistic=msg.statistic if msg.statistic else None)
        self.clock.observe(was_flagged, state, frame_end)
        return state

    def reset(self) -> AnomalyState:
        """Telecommanded reset of the detector."""
        return self.detector.reset()

    def report(self, state: AnomalyState, t: float) -> m.AnomalyReport:
        """The ICD report of ``state`` (``t``: see :func:`anomaly_message`)."""
        return anomaly_message(state, t, self.clock)

    def news(self, state: AnomalyState) -> bool:
        """Whether ``state`` changes what the ground was last told (flag, class or declaration).
        True marks it as told: the caller then reports it."""
        key = (state.flag, state.anomaly_class, state.declared_t)
        if key == self._last_reported:
            return False
        self._last_reported = key
        return True

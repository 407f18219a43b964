"""The FSW's ICD messages and the one rule that dates an anomaly declaration."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.astro.time import tdb_to_unix
from fsw.core.telemetry import AnomalyReporter, DeclarationClock, anomaly_message, budget_message, stamp, weights_message
from fsw.executive.report import ICD_FIELDS, BudgetReportData
from fsw.fdir.config import DetectorConfig
from fsw.fdir.detector import AnomalyDetector, AnomalyState
from fsw.fdir.families import FilterFamily
from fsw.gating.base import WeightsUpdate
from fsw.interface import codec, messages as m

FILTERS = ("radio", "optical", "fused")
FAMILIES = (FilterFamily(name="radio", families=("radiometric",)), FilterFamily(name="optical", families=("optical",)),
            FilterFamily(name="fused", families=("radiometric", "optical")))


def _state(t, flag, declared=None, cls="none", conf=0.0) -> AnomalyState:
    return AnomalyState(network="chi2", t=t, flag=flag, anomaly_class=cls, confidence=conf, onset_t=None,
                        declared_t=declared, cleared_t=None, statistic=None, threshold=8.0)


@pytest.mark.parametrize("t", [0.0, 1234.5678, 7.5e8 + 3599.999, 8.1e8 + 0.25])
def test_stamp_is_the_utc_of_the_tdb_epoch_to_microseconds(t):
    assert stamp(t).to_unix() == pytest.approx(float(tdb_to_unix(t)), abs=2e-6)


def test_the_hourly_offsets_converted_together_are_those_converted_one_by_one():
    # ±2.3 years of hours about the default scenario's epoch (the 2016-12-31 leap second included);
    # misses in every order: forwards, backwards, and a cache cleared half-way
    from fsw.core import telemetry

    hours = list(range(int(5.2e8 // 3600), int(6.6e8 // 3600), 7))
    one_by_one = [float(tdb_to_unix(h * 3600.0)) - h * 3600.0 for h in hours]
    for order in (hours, hours[::-1]):
        telemetry._OFFSETS.clear()
        got = {h: telemetry._unix_offset(h) for h in order}
        assert [got[h] for h in hours] == one_by_one
    assert len(telemetry._OFFSETS) <= telemetry._OFFSETS_KEPT
    stamps = [stamp(h * 3600.0 + 1234.5) for h in hours[:200]]
    telemetry._OFFSETS.clear()
    assert [stamp(h * 3600.0 + 1234.5) for h in hours[:200]] == stamps


@pytest.mark.parametrize("mode", ["cpu", "work-units"])
def test_budget_message_is_the_report_field_by_field(mode):
    # every field a different value, so that two fields swapped could not go unnoticed
    rep = BudgetReportData(frame=3, t_s=7.5e8 + 60.0, mode=mode, used=0.25, budget=2.0, utilisation=0.125,
                           processed=7, deferred=5, backlog=2, overruns=11, errors=13, lag_s=17.0,
                           backlog_warning=True)
    by_name = m.BudgetReport(timestamp=stamp(rep.t_s), **{name: getattr(rep, name) for name in ICD_FIELDS})
    msg = budget_message(rep)
    assert msg == by_name
    assert codec.from_json(m.BudgetReport, codec.to_json(msg)) == by_name


def test_weights_message_carries_groups_and_statistic_when_the_network_has_them():
    flat = WeightsUpdate("chi2", 10.0, 3, 0, FILTERS, np.array([0.5, 0.25, 0.25]))
    msg = weights_message(flat)
    assert (msg.t_s, msg.batch, msg.filters, msg.weights) == (10.0, 0, FILTERS, (0.5, 0.25, 0.25))
    assert msg.statistic == () and msg.groups == {}
    two = WeightsUpdate("hierarchical", 11.0, 4, 1, FILTERS, np.array([0.5, 0.25, 0.25]),
                        statistic=np.array([1.0, 2.0, 3.0]), group_names=("a", "b"),
                        group_weights=np.array([0.75, 0.25]))
    msg = weights_message(two)
    assert msg.statistic == (1.0, 2.0, 3.0) and msg.groups == {"a": 0.75, "b": 0.25}
    # built by position: the whole message, field by field, against the one built by name
    assert msg == m.FilterWeights(t_s=11.0, timestamp=stamp(11.0), network="hierarchical", batch=1, filters=FILTERS,
                                  weights=(0.5, 0.25, 0.25), groups={"a": 0.75, "b": 0.25}, statistic=(1.0, 2.0, 3.0))
    assert codec.from_json(m.FilterWeights, codec.to_json(msg)) == msg  # a valid ICD message


def test_a_declaration_is_dated_by_the_end_of_the_frame_that_made_it():
    clock = DeclarationClock()
    quiet = _state(100.0, False)
    clock.observe(False, quiet, frame_end=130.0)
    assert clock.declared_s(quiet) is None
    raised = _state(200.0, True, declared=200.0)
    clock.observe(False, raised, frame_end=260.0)  # the gating ran a minute after the data
    assert clock.declared_s(raised) == 260.0
    # held while the flag stays up, whatever later frames end at
    later = _state(300.0, True, declared=200.0)
    clock.observe(True, later, frame_end=900.0)
    assert clock.declared_s(later) == 260.0
    # a new declaration made outside the frames (end of run) is known at its data epoch
    again = _state(1000.0, True, declared=1000.0)
    clock.observe(False, again, frame_end=None)
    assert clock.declared_s(again) == 1000.0
    # a frame cannot end before its data: the data epoch bounds the date from below
    clock.observe(False, _state(2000.0, True, declared=2000.0), frame_end=1990.0)
    assert clock.declared_s(_state(2000.0, True, declared=2000.0)) == 2000.0


def test_anomaly_message_clamps_confidence_and_dates_a_state_without_epoch():
    clock = DeclarationClock()
    msg = anomaly_message(_state(None, False), 42.0, clock)
    assert msg.t_s == 42.0 and not msg.flag and msg.declared_s is None and msg.network == "chi2"
    msg = anomaly_message(_state(50.0, True, declared=50.0, cls="dynamics", conf=1.5), 42.0, clock)
    assert msg.t_s == 50.0 and msg.confidence == 1.0 and msg.anomaly_class == "dynamics"
    assert msg.declared_s == 50.0


def _calibration() -> DetectorConfig:
    return DetectorConfig(network="chi2", filters=FILTERS, nominal_mean=(1 / 3,) * 3,
                          nominal_cov=tuple(tuple(1e-5 * (i == j) for j in range(3)) for i in range(3)),
                          threshold=8.0, clear_threshold=4.0, onset_reference=2.0, persistence_k=2,
                          persistence_n=3, hold=3)


def _updates() -> list[WeightsUpdate]:
    nominal, skewed = (1 / 3, 1 / 3, 1 / 3), (0.2, 0.6, 0.2)
    seq = [nominal] * 3 + [skewed] * 5 + [nominal] * 5 + [skewed] * 2
    return [WeightsUpdate("chi2", 1000.0 * (k + 1), 10 * k, k, FILTERS, np.array(w), statistic=np.arange(3.0) + k)
            for k, w in enumerate(seq)]


def test_reporter_on_recorded_weights_reports_what_the_onboard_one_reported():
    onboard = AnomalyReporter(AnomalyDetector(_calibration(), FAMILIES))
    ground = AnomalyReporter(AnomalyDetector(_calibration(), FAMILIES))
    ups = _updates()
    # each batch's gating stage ran in a frame ending 250 s after its data, the last one outside
    # any frame (a batch closed at the end of the run)
    frames: list[float | None] = [u.t + 250.0 for u in ups[:-1]] + [None]
    mine = [onboard.report(onboard.consume(u, f), u.t) for u, f in zip(ups, frames)]
    theirs = [ground.report(ground.consume_weights(weights_message(u), f), u.t) for u, f in zip(ups, frames)]
    assert mine == theirs
    flags = [r.flag for r in mine]
    # declared on the second skewed batch (2 of 3), cleared by the third quiet one (hold 3),
    # declared again on the second skewed batch after it
    assert flags == [False] * 4 + [True] * 6 + [False] * 4 + [True]
    first = mine[4]
    assert first.declared_s == first.t_s + 250.0
    assert {r.declared_s for r in mine[4:10]} == {first.declared_s}
    assert all(r.declared_s is None for r in mine[10:14])
    assert mine[14].declared_s == mine[14].t_s  # known at its data epoch


def test_news_is_a_change_of_flag_class_or_declaration():
    rep = AnomalyReporter(AnomalyDetector(_calibration(), FAMILIES))
    assert rep.news(_state(1.0, False))
    assert not rep.news(_state(2.0, False))  # only the epoch moved
    assert rep.news(_state(3.0, True, declared=3.0, cls="unknown"))
    assert rep.news(_state(4.0, True, declared=3.0, cls="optical-measurement"))
    assert not rep.news(_state(5.0, True, declared=3.0, cls="optical-measurement"))


def test_best_estimate_is_a_filter_estimate_relabelled():
    """Each hour's "best" Estimate is, field for field, the Estimate of one of the filters sent
    at the same epoch, under its own label (the core builds it once and relabels it)."""
    import dataclasses

    from tools.bench.core import scenario
    from tools.inprocess import run_in_process

    out = run_in_process(scenario(span_days=1.0), 1)
    by_t: dict[float, dict[str, m.Estimate]] = {}
    for topic, msg in out.messages:
        if topic.startswith("fsw/estimate/"):
            by_t.setdefault(msg.t_s, {})[topic.rsplit("/", 1)[1]] = msg
    checked = 0
    for t, msgs in by_t.items():
        best = msgs.get("best")
        if best is None:
            continue
        assert best.filter == "best"
        twins = [label for label in FILTERS if dataclasses.replace(msgs[label], filter="best") == best]
        assert len(twins) >= 1, t
        checked += 1
    assert checked >= 20

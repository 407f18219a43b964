"""Residual and B-plane telemetry: built from what the bank computed, batched, ICD round trip."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.core.telemetry import residual_sample, residuals_message
from fsw.filters.record import BankRecord
from fsw.interface import codec, messages as m


def test_residual_sample_equals_an_independent_linear_computation():
    rng = np.random.default_rng(7)
    n_filters, n_states, n_meas = 3, 4, 2
    H = rng.normal(size=(n_meas, n_states))
    R = np.diag([0.3, 0.5]) ** 2
    y = rng.normal(size=n_meas)
    xs = [rng.normal(size=n_states) for _ in range(n_filters)]
    Ps = [np.diag(rng.uniform(0.1, 2.0, n_states)) for _ in range(n_filters)]
    # the bank's record of a linear measurement y = H x + v
    z = np.array([y - H @ x for x in xs])
    S = np.array([H @ P @ H.T + R for P in Ps])
    chi2 = np.array([zi @ np.linalg.solve(Si, zi) for zi, Si in zip(z, S)])
    rec = BankRecord(t=12.0, seq=4, kind="optical", filters=("a", "b", "c"), residual=z, S=S, chi2=chi2,
                     processed=np.array([True, False, True]))
    sample = residual_sample(rec, "phobos")
    for i in range(n_filters):
        for k in range(n_meas):
            sigma = np.sqrt((H @ Ps[i] @ H.T)[k, k] + R[k, k])
            assert sample.residual[i][k] == pytest.approx(y[k] - H[k] @ xs[i], rel=1e-12)
            assert sample.sigma[i][k] == pytest.approx(sigma, rel=1e-12)
            assert sample.normalised[i][k] == pytest.approx((y[k] - H[k] @ xs[i]) / sigma, rel=1e-12)
    assert sample.nis == pytest.approx(tuple(chi2))
    assert sample.processed == (True, False, True) and sample.source == "phobos" and sample.seq == 4


def test_scalar_residual_sample_is_each_field_computed_by_name():
    # the scalar path (range, Doppler) builds the message by position: every field here differs
    # from the others, so two swapped fields, or a wrong element, fail
    z = np.array([[2.5e-4], [-3.0e-4], [0.0]])
    S = np.array([[[4.0e-8]], [[0.0]], [[9.0e-8]]])
    chi2 = np.array([1.5625, 0.0, 0.0])
    rec = BankRecord(t=96.5, seq=11, kind="doppler", filters=("a", "b", "c"), residual=z, S=S, chi2=chi2,
                     processed=np.array([True, False, True]))
    sample = residual_sample(rec, "DSS-43")
    sigma = (np.sqrt(4.0e-8), 0.0, np.sqrt(9.0e-8))
    assert sample == m.ResidualSample(
        t_s=96.5, seq=11, kind="doppler", source="DSS-43", residual=((2.5e-4,), (-3.0e-4,), (0.0,)),
        sigma=tuple((s,) for s in sigma), normalised=((2.5e-4 / sigma[0],), (0.0,), (0.0,)),
        nis=(1.5625, 0.0, 0.0), processed=(True, False, True))
    assert all(type(v) is float for row in sample.residual + sample.sigma + sample.normalised for v in row)
    assert all(type(v) is float for v in sample.nis) and all(type(v) is bool for v in sample.processed)


def test_residuals_and_bplane_round_trip_through_the_icd():
    sample = m.ResidualSample(t_s=1.0, seq=0, kind="range", source="DSS-14", residual=((0.1,), (0.2,)),
                              sigma=((1.0,), (2.0,)), normalised=((0.1,), (0.1,)), nis=(0.01, 0.01),
                              processed=(True, False))
    msg = residuals_message(2.0, ("a", "b"), [sample, sample])
    assert codec.from_json(m.Residuals, codec.to_json(msg)) == msg
    bp = m.BPlane(t_s=1.0, timestamp=m.Stamp(1, 0), filter="combined", b_dot_r_km=500.0, b_dot_t_km=6600.0,
                  covariance_km2=((4.0, 1.0), (1.0, 9.0)), periapsis_s=2e5, periapsis_sigma_s=3.0, v_inf_km_s=2.9)
    assert codec.from_json(m.BPlane, codec.to_json(bp)) == bp
    with pytest.raises(ValueError):
        m.ResidualSample(t_s=1.0, seq=0, kind="range", source="x", residual=((0.1,),), sigma=(), normalised=(),
                         nis=(0.0,), processed=(True,))


def test_core_reports_every_filtered_measurement_once_in_few_messages():
    from tools.inprocess import run_in_process
    from tools.scenario import load_text_scenario

    cfg = load_text_scenario("name: s\nsim:\n  trajectory: {span_days: 1.0}\nfsw:\n  budget: {mode: work-units}\n"
                             "  telemetry: {residuals_every_s: 600.0, bplane_every_s: 21600.0}\n")
    run = run_in_process(cfg, seed=3)
    meas = [msg for t, msg in run.messages if t == "sim/measurements"]
    res = [msg for t, msg in run.messages if t == "fsw/residuals"]
    seqs = [s.seq for r in res for s in r.samples]
    assert seqs == sorted(seqs) and set(seqs) == {x.seq for x in meas}
    assert len(res) <= 1 + (86400 / 600)
    assert all(r.filters == res[0].filters for r in res)
    bplanes = [msg for t, msg in run.messages if t == "fsw/bplane/combined"]
    assert len(bplanes) >= 3 and all(b.v_inf_km_s > 1.0 for b in bplanes)
    # the best estimate is one filter's: its targeting is that filter's, relabelled
    import dataclasses

    per_filter = {(msg.t_s, dataclasses.replace(msg, filter="best")) for t, msg in run.messages
                  if t.startswith("fsw/bplane/") and t.rsplit("/", 1)[1] in res[0].filters}
    best = [msg for t, msg in run.messages if t == "fsw/bplane/best"]
    assert len(best) == len(bplanes) and all(b.filter == "best" and (b.t_s, b) in per_filter for b in best)


def test_campaign_report_pools_nis_over_runs_weighted_by_counts():
    from ground.report.markdown import _campaign_nis_lines

    def row(count: int, mean: float, outside: float) -> dict:
        return {"summary": {"nis": {"range": {"radio": {"count": count, "dimension": 1, "mean_nis": mean,
                                                         "outside_95": outside}}}}}

    lines = _campaign_nis_lines([row(100, 1.0, 0.05), row(300, 2.0, 0.25), {"summary": {}}])
    table = [ln for ln in lines if ln.startswith("| range")]
    assert table == ["| range | radio | 2 | 400 | 1 | 1.75 | 1 – 2 | 20.0 % |"]
    assert _campaign_nis_lines([{"summary": {"nis": None}}]) == []


def test_samples_sent_later_are_those_of_the_records_as_the_bank_made_them():
    # The core keeps a frame's records and makes their samples when the Residuals message goes
    # out: nothing between the bank stage and that moment (gating, detector, the next
    # measurements' stages) may have changed a record. A tap samples each record the moment the
    # bank returns it, independently of the core's own sampling.
    from fsw.core import FswCore
    from sim.stream import generate
    from tools.scenario import load_text_scenario, resolve

    cfg = load_text_scenario("name: s\nsim:\n  trajectory: {span_days: 1.0}\nfsw:\n  budget: {mode: work-units}\n"
                             "  telemetry: {residuals_every_s: 3600.0}\n")
    resolved, seed = resolve(cfg, 5)
    run = generate(resolved.sim, seed=seed)
    out: list = []
    core = FswCore(resolved.fsw, lambda topic, msg: out.append((topic, msg)))
    at_once: list[m.ResidualSample] = []
    sources = {x.seq: x.source for x in run.measurements}
    core.record_taps = (lambda rec: at_once.append(residual_sample(rec, sources[rec.seq])),)
    core.start()
    for x in run.measurements:
        core.ingest(x)
    core.finish()
    sent = [s for t, msg in out if t == "fsw/residuals" for s in msg.samples]
    assert len(sent) == len(at_once) > 100 and {s.kind for s in sent} == {"range", "doppler", "optical"}
    assert sent == at_once

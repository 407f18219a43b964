"""The measurement stream: determinism, independence, statistics, ordering, truth, io, speed."""

import json
import time

import numpy as np
import pytest

from fsw.interface import topics
from fsw.interface.messages import FaultEvent, Measurement, Truth
from sim.config import SimConfig
from sim.dynamics.config import TrajectoryConfig
from sim.faults.presets import preset
from sim.io import JsonlError, read_jsonl, write_run
from sim.scenarios import chaer_tracking
from sim.stream import component_seeds, generate, linear_tracking_run

DAY = 86400.0


@pytest.fixture(scope="module")
def run():
    return generate(seed=3)


def test_same_seed_gives_identical_bytes_and_other_seeds_differ(run, tmp_path):
    again = generate(seed=3)
    a, b = tmp_path / "a.jsonl", tmp_path / "b.jsonl"
    n = write_run(run, a)
    write_run(again, b)
    assert n == len(run.measurements) + len(run.truth) + len(run.fault_events)
    assert a.read_bytes() == b.read_bytes()
    other = generate(seed=4)
    # Independent noise, clock and force dispersions.
    assert not np.array_equal(run.radio.noise[:100], other.radio.noise[:100])
    assert not np.array_equal(run.optical.noise[:100], other.optical.noise[:100])
    assert run.clock.nodes[0, 0] != other.clock.nodes[0, 0]
    assert run.truth[-1].position_km != other.truth[-1].position_km
    assert run.truth[0].srp_scale != other.truth[0].srp_scale
    zr = run.radio.noise[run.radio.kind == "doppler"][:2000]
    zo = other.radio.noise[other.radio.kind == "doppler"][:2000]
    assert abs(np.corrcoef(zr, zo)[0, 1]) < 0.1
    seeds = component_seeds(3)
    draws = [np.random.default_rng(s).standard_normal(1000) for s in seeds.values()]
    assert max(abs(np.corrcoef(draws)[i, j]) for i in range(4) for j in range(i)) < 0.15
    with pytest.raises(ValueError):
        component_seeds(-1)


def test_stream_statistics(run):
    m = run.measurements
    counts = run.counts()
    assert len(m) >= 20_000
    assert set(counts) == {"range", "doppler", "optical"}
    kinds = np.array([x.kind for x in m])
    radio = np.isin(kinds, ("range", "doppler")).astype(int)
    optical = (kinds == "optical").astype(int)
    both = (np.convolve(radio, np.ones(500, int), "valid") > 0) & (np.convolve(optical, np.ones(500, int), "valid") > 0)
    assert both.mean() > 0.9
    assert np.degrees(run.radio.elevation_rad).min() >= 10.0
    px = np.array([x.value for x in m if x.kind == "optical"])
    assert np.all((px >= 0.5) & (px <= 1024.5))
    q = np.array([x.attitude_q for x in m if x.kind == "optical"])
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    sources = {x.source for x in m if x.kind == "optical"}
    assert {"mars", "phobos", "deimos"} <= sources and len(sources - {"mars", "phobos", "deimos"}) >= 3  # beacons
    assert all(x.count_time_s == 60.0 for x in m if x.kind == "doppler")


def test_order_sequence_and_time_tags(run):
    m = run.measurements
    assert [x.seq for x in m] == list(range(len(m)))
    t_true = run.t_true
    assert np.all(np.diff(t_true) >= 0.0)
    tags = np.array([x.t_s for x in m])
    # Tags are the onboard clock reading at the true reception time.
    np.testing.assert_allclose(tags - t_true, run.clock.phase(t_true), rtol=0, atol=2.5e-7)
    assert np.all(t_true >= run.t_start) and np.all(t_true <= run.t_end)
    stamps = np.array([x.timestamp.to_unix() for x in m[:100]])
    assert np.all(np.diff(stamps) >= 0.0) and 1.53e9 < stamps[0] < 1.55e9  # October 2018


def test_truth_messages_and_exact_truth(run):
    tr = run.truth
    t = np.array([x.t_s for x in tr])
    np.testing.assert_allclose(np.diff(t), 600.0, rtol=1e-9)
    assert t[0] == run.t_start and len(tr) == 45 * 144 + 1
    k = 1234
    exact = run.truth_at(t[k])
    assert exact == tr[k]
    x = run.state_at(t[k])
    np.testing.assert_array_equal(x[:3], tr[k].position_km)
    b, f, _ = run.clock.state(t[k])
    assert tr[k].clock_phase_s == b and tr[k].clock_frequency == f
    # Truth at any instant: positions close to the 10-min grid neighbours, speed consistent.
    mid = run.truth_at(t[k] + 300.0)
    dx = np.subtract(mid.position_km, tr[k].position_km)
    assert np.linalg.norm(dx) == pytest.approx(300.0 * np.linalg.norm(tr[k].velocity_km_s), rel=1e-3)


def test_truth_at_every_measurement_when_asked():
    cfg = SimConfig(trajectory=TrajectoryConfig(span_days=2.0), truth_interval_s=0.0)
    short = generate(cfg, seed=1)
    assert len(short.truth) == np.unique(short.t_true).size
    assert {x.t_s for x in short.truth} == set(short.t_true.tolist())


def test_iter_messages_is_time_ordered_and_complete(run):
    bad = generate(faults=preset("radio-bias-small", onset_day=0.5), seed=3,
                   cfg=SimConfig(trajectory=TrajectoryConfig(span_days=2.0)))
    msgs = list(bad.iter_messages())
    assert len(msgs) == len(bad.measurements) + len(bad.truth) + len(bad.fault_events)
    times = []
    for (topic, msg) in msgs:
        assert topics.type_of_topic(topic) is type(msg)
        times.append(bad.t_true[msg.seq] if isinstance(msg, Measurement) else msg.t_s)
    assert np.all(np.diff(times) >= 0.0)
    first_fault = next(i for i, (_, m) in enumerate(msgs) if isinstance(m, FaultEvent))
    assert all(times[i] < msgs[first_fault][1].t_s for i in range(first_fault))


def test_iter_messages_order_is_time_then_fault_truth_measurement_then_index():
    """The order written out as its rule (a sort on (time, stream, index) of Python tuples), on a
    run with ties at every measurement (truth at each one) and fault events."""
    cfg = SimConfig(trajectory=TrajectoryConfig(span_days=1.0), truth_interval_s=0.0)
    tied = generate(cfg, faults=preset("radio-bias-small", onset_day=0.25), seed=5)
    keyed = [(e.t_s, 0, i, topics.SIM_FAULTS, e) for i, e in enumerate(tied.fault_events)]
    keyed += [(x.t_s, 1, i, topics.SIM_TRUTH, x) for i, x in enumerate(tied.truth)]
    keyed += [(float(t), 2, i, topics.SIM_MEASUREMENTS, x)
              for i, (t, x) in enumerate(zip(tied.t_true.tolist(), tied.measurements))]
    expected = [(k[3], k[4]) for k in sorted(keyed, key=lambda k: k[:3])]
    got = list(tied.iter_messages())
    assert len(got) == len(expected) and tied.fault_events and len(tied.truth) == np.unique(tied.t_true).size
    assert all(a[0] == b[0] and a[1] is b[1] for a, b in zip(got, expected))
    ties = sum(1 for (_, a), (_, b) in zip(got, got[1:]) if isinstance(a, Truth) and isinstance(b, Measurement))
    assert ties > 100  # truth ahead of the measurement at its own time, again and again


def test_jsonl_round_trip_and_rejection(run, tmp_path):
    path = tmp_path / "run.jsonl"
    cfg = SimConfig(trajectory=TrajectoryConfig(span_days=1.0))
    small = generate(cfg, faults=preset("optical-bias-large", onset_day=0.25), seed=9)
    write_run(small, path)
    back = read_jsonl(path)
    assert back == [(topics.mcap_topic(t), m) for t, m in small.iter_messages()]
    first = json.loads(path.read_text().splitlines()[0])
    assert set(first) == {"topic", "type", "msg"}
    kinds = {type(m) for _, m in back}
    assert kinds == {Measurement, Truth, FaultEvent}
    bad = tmp_path / "bad.jsonl"
    line = json.loads(path.read_text().splitlines()[-1])
    line["topic"] = "/sim/truth" if line["type"] == "Measurement" else "/sim/measurements"
    bad.write_text(json.dumps(line) + "\n")
    with pytest.raises(JsonlError, match="bad.jsonl:1"):
        read_jsonl(bad)
    bad.write_text('{"topic": "/sim/measurements", "type": "Measurement", "msg": {"seq": -1}}\n')
    with pytest.raises(JsonlError):
        read_jsonl(bad)


def test_linear_tracking_wraps_as_generic_linear():
    track = chaer_tracking.experiment_3(np.random.default_rng(0), segment_length=20)
    lin = linear_tracking_run(track)
    m = lin.measurements
    assert len(m) == 100 and all(x.kind == "generic-linear" and x.source == "chaer-tracking" for x in m)
    np.testing.assert_array_equal([x.value for x in m], track.z)
    alpha = np.asarray(chaer_tracking.TABLE_III)
    np.testing.assert_allclose([x.sigma for x in m], np.sqrt(alpha[track.segment][:, 2:4]))
    assert [x.t_s for x in m] == list(track.t)
    assert [t for t, _ in lin.iter_messages()] == [topics.SIM_MEASUREMENTS] * 100
    with pytest.raises(ValueError):
        lin.truth_at(1.0)


def test_full_stream_generates_in_under_ten_seconds(run):
    t0 = time.perf_counter()
    generate(seed=17)
    elapsed = time.perf_counter() - t0
    print(f"45-day stream generated in {elapsed:.2f} s")
    assert elapsed < 10.0


def test_bad_seed_and_fault_after_the_end_are_rejected():
    with pytest.raises(ValueError):
        generate(seed=-3)
    with pytest.raises(ValueError):
        generate(cfg=SimConfig(trajectory=TrajectoryConfig(span_days=2.0)), faults=preset("clock-bias"), seed=1)

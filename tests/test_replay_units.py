"""Replay building blocks: raw reading, config overrides, message comparison, republication pacing."""

from __future__ import annotations

import dataclasses
import threading
import time

import pytest

from fsw import transport as T
from fsw.interface import codec
from fsw.interface import messages as m
from fsw.interface.yamlconfig import ConfigError
from ground.mcap_io import McapRecorder
from ground.replay.compare import compare_messages, compare_runs, flatten
from ground.replay.fsw_config import load_fsw_config, parse_override
from ground.replay.recording import iter_raw, run_info
from ground.replay.republish import republish
from ground.replay.rerun import recorded_measurement_stream

STAMP = m.Stamp(sec=1_543_233_531, nsec=0)
T0_NS = 1_700_000_000 * 10**9


def _meas(seq: int) -> m.Measurement:
    return m.Measurement(seq=seq, t_s=6e8 + 60.0 * seq, timestamp=STAMP, kind="range", source="DSS-14",
                         value=(1.5e8 + seq,), sigma=(1e-3,))


def _weights(w: tuple[float, float], t: float = 6e8) -> m.FilterWeights:
    return m.FilterWeights(t_s=t, timestamp=STAMP, network="chi2", batch=0, filters=("radio", "optical"), weights=w)


def _anomaly(cls: str, flag: bool, onset: float | None) -> m.AnomalyReport:
    return m.AnomalyReport(t_s=6e8, timestamp=STAMP, flag=flag, anomaly_class=cls, confidence=0.5, onset_s=onset)


# --------------------------------------------------------------------------------------------
# comparison
# --------------------------------------------------------------------------------------------


def test_flatten_folds_nothing_and_keeps_paths():
    flat = flatten({"a": [1, [2, 3]], "b": {"c": None}, "d": [], "e": True})
    assert flat == {"a[0]": 1, "a[1][0]": 2, "a[1][1]": 3, "b.c": None, "d": [], "e": True}


def test_identical_messages_compare_equal():
    td = compare_messages("/fsw/weights/chi2", [_weights((0.25, 0.75))], [_weights((0.25, 0.75))])
    assert td.identical(0.0) and td.max_abs == 0.0 and td.mismatches == 0


def test_weight_difference_is_the_largest_element_difference():
    rec = [_weights((0.25, 0.75)), _weights((0.5, 0.5), t=6e8 + 1)]
    new = [_weights((0.25, 0.75)), _weights((0.3, 0.7), t=6e8 + 1)]
    td = compare_messages("/fsw/weights/chi2", rec, new)
    f = td.fields["weights"]
    assert f.max_abs == pytest.approx(0.2, abs=1e-15)  # |0.5 - 0.3| = |0.5 - 0.7|
    assert f.worst_index == 1 and f.worst_t_s == 6e8 + 1
    assert td.identical(0.25) and not td.identical(0.1)


def test_fields_are_compared_in_the_message_s_order_whatever_the_hash_seed():
    """Fields of equal difference: the report names the first in the recorded message's order, in
    every process (a set of field paths would order them by the string hash seed)."""
    import subprocess
    import sys

    code = ("from ground.replay.compare import compare_messages\n"
            "rec = [{'t_s': 1.0, 'position_km': [1.0, 2.0, 3.0], 'state': [1.0, 2.0, 3.0, 4.0]}]\n"
            "new = [{'t_s': 1.0, 'position_km': [1.5, 2.0, 3.0], 'state': [1.5, 2.0, 3.0, 4.0]}]\n"
            "more = [{**new[0], 'extra': 1}]\n"
            "print(compare_messages('/fsw/estimate/radio', rec, new).worst_field(),\n"
            "      list(compare_messages('/fsw/estimate/radio', rec, more).fields))")
    seen = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                           env={**__import__("os").environ, "PYTHONHASHSEED": str(seed)}).stdout.strip()
            for seed in range(6)}
    assert seen == {"position_km ['t_s', 'position_km', 'state', 'extra']"}


def test_relative_tolerance_is_counted_leaf_by_leaf():
    rec = [_weights((1e-3, 1.0 - 1e-3)), _weights((0.5, 0.5), t=6e8 + 1)]
    new = [_weights((1e-3 * (1 + 4e-10), 1.0 - 1e-3)), _weights((0.5, 0.5 * (1 - 2e-9)), t=6e8 + 1)]
    f = compare_messages("/fsw/weights/chi2", rec, new).fields["weights"]
    assert f.max_rel == pytest.approx(2e-9, rel=1e-6) and f.worst_rel_index == 1
    # 4e-10 and 2e-9 relative: within 3e-9, not within 1e-9 (only the second leaf is outside)
    assert compare_messages("/fsw/weights/chi2", rec, new, rtol=3e-9).identical(0.0)
    td = compare_messages("/fsw/weights/chi2", rec, new, rtol=1e-9)
    assert not td.identical(0.0) and td.fields["weights"].outside == 1
    # a leaf within the absolute tolerance passes whatever its relative difference
    assert compare_messages("/fsw/weights/chi2", rec, new, tolerance=2e-9, rtol=1e-12).identical(2e-9)


def test_anomaly_class_flag_and_onset_differences():
    rec = [_anomaly("none", False, None)]
    new = [_anomaly("optical-measurement", True, 6e8 - 3600.0)]
    td = compare_messages("/fsw/anomaly", rec, new)
    assert td.fields["flag"].max_abs == 1.0  # a flag counts as 0/1
    assert td.fields["anomaly_class"].mismatches == 1
    assert "optical-measurement" in td.fields["anomaly_class"].example
    assert td.fields["onset_s"].mismatches == 1  # null vs a number
    assert not td.identical(10.0)  # categorical mismatches fail whatever the tolerance


def test_count_difference_fails_and_missing_topics_count():
    cmp = compare_runs({"/fsw/weights/chi2": [_weights((0.25, 0.75))] * 3},
                       {"/fsw/weights/chi2": [_weights((0.25, 0.75))] * 2, "/fsw/anomaly": [_anomaly("none", False, None)]})
    assert not cmp.identical
    assert (cmp.topics["/fsw/weights/chi2"].recorded, cmp.topics["/fsw/weights/chi2"].rerun) == (3, 2)
    assert cmp.topics["/fsw/anomaly"].recorded == 0


def test_counts_only_topics_are_not_compared():
    budget = m.BudgetReport(frame=1, t_s=6e8, timestamp=STAMP, mode="cpu", used=0.1, budget=1.0, utilisation=0.1,
                            processed=1, deferred=0, backlog=0, overruns=0)
    other = dataclasses.replace(budget, used=0.3)
    cmp = compare_runs({"/fsw/budget": [budget]}, {"/fsw/budget": [other, other]},
                       counts_only={"/fsw/budget": "cpu"})
    assert cmp.identical


def test_status_keys_on_one_side_are_listed_not_compared():
    rec = m.RunStatus(t_s=1.0, timestamp=STAMP, run_id="r", source="fsw", state="end-of-run",
                      counts={"processed": 5, "transport_gaps": 0})
    new = dataclasses.replace(rec, counts={"processed": 5})
    td = compare_messages("/fsw/status", [rec], [new])
    assert td.identical(0.0) and td.one_sided == {"transport_gaps (only recorded)"}
    td = compare_messages("/fsw/status", [rec], [dataclasses.replace(rec, counts={"processed": 4, "transport_gaps": 0})])
    assert td.fields["counts.processed"].max_abs == 1.0


def test_a_status_authentication_tag_is_not_compared_but_its_contents_are():
    rec = m.RunStatus(t_s=1.0, timestamp=STAMP, run_id="r", source="fsw", state="end-of-run", counts={"processed": 5},
                      auth=m.AuthTag(nonce="ab" * 16, mac="cd" * 32))
    plain = dataclasses.replace(rec, auth=None)
    assert compare_messages("/fsw/status", [rec], [plain]).identical(0.0)
    assert not compare_messages("/fsw/status", [rec], [dataclasses.replace(plain, state="running")]).identical(0.0)


# --------------------------------------------------------------------------------------------
# configuration from the recording
# --------------------------------------------------------------------------------------------

SCENARIO = """\
name: unit
seed: 1
sim:
  trajectory: {span_days: 1.0}
fsw:
  budget: {mode: work-units}
  gating:
    - {network: chi2, batch_size: 50}
    - {network: magill}
  initial_state:
    t_s: 596188089.0
    position_km: [-367306.0, 900236.0, 381784.0]
    velocity_km_s: [1.0, -2.5, -1.0]
"""


def test_recorded_config_loads_the_fsw_section():
    cfg = load_fsw_config(SCENARIO, "run.mcap:config.yaml")
    assert cfg.budget.mode == "work-units"
    assert cfg.gating[0].network == "chi2" and cfg.gating[0].params.batch_size == 50
    assert cfg.initial_state.position_km == (-367306.0, 900236.0, 381784.0)


def test_set_overrides_one_value():
    cfg = load_fsw_config(SCENARIO, "f", overrides=["fsw.gating[0].sigma_w=0.1", "fsw.budget.mode=cpu"])
    assert cfg.gating[0].params.sigma_w == 0.1 and cfg.budget.mode == "cpu"
    assert cfg.gating[0].params.batch_size == 50


def test_parse_override_paths_and_values():
    assert parse_override("fsw.gating[1].prior=[0.5, 0.5]") == (["gating", 1, "prior"], [0.5, 0.5])
    assert parse_override("fsw.detector.calibration=null") == (["detector", "calibration"], None)
    for bad in ("fsw.gating[0].sigma_w", "sim.trajectory.span_days=2", "fsw..x=1", "fsw.a[x]=1", "fsw=1"):
        with pytest.raises(ValueError):
            parse_override(bad)


def test_bad_override_is_one_config_error_naming_the_option():
    with pytest.raises(ConfigError) as err:
        load_fsw_config(SCENARIO, "f", overrides=["fsw.gating[0].sigma_w=-1"])
    text = str(err.value)
    assert "\n" not in text and "--set fsw.gating[0].sigma_w=-1" in text and "fsw.gating[0].sigma_w" in text
    with pytest.raises(ValueError, match="does not exist"):
        load_fsw_config(SCENARIO, "f", overrides=["fsw.gating[5].sigma_w=0.1"])


def test_bad_recorded_value_points_at_its_line():
    bad = SCENARIO.replace("batch_size: 50", "batch_size: -3")
    with pytest.raises(ConfigError) as err:
        load_fsw_config(bad, "run.mcap:config.yaml")
    assert str(err.value).startswith("run.mcap:config.yaml:8: fsw.gating[0].batch_size")


def test_replacement_config_keeps_the_recorded_initial_state(tmp_path):
    path = tmp_path / "new.yaml"
    path.write_text("gating:\n  - {network: chi2, batch_size: 10}\n")
    cfg = load_fsw_config(SCENARIO, "f", replacement=path)
    assert [g.network for g in cfg.gating] == ["chi2"] and cfg.gating[0].params.batch_size == 10
    assert cfg.initial_state.t_s == 596188089.0
    assert cfg.budget.mode == "cpu"  # the replacement's (default), not the recorded one
    scen = tmp_path / "scen.yaml"
    scen.write_text("name: x\nfsw:\n  gating:\n    - {network: magill}\n  detector: {network: magill}\n")
    assert [g.network for g in load_fsw_config(SCENARIO, "f", replacement=scen).gating] == ["magill"]


# --------------------------------------------------------------------------------------------
# reading raw records
# --------------------------------------------------------------------------------------------


def _recording(path, n: int = 20, span_s: float = 1.0) -> list[tuple[str, bytes]]:
    """A small recording: measurements (one out of order, one malformed), weights, an unknown topic."""
    sent = []
    with McapRecorder(path) as rec:
        rec.add_attachment("config.yaml", SCENARIO.encode(), "application/yaml")
        rec.add_metadata("navbank.run", {"run_id": "orig-run"})
        order = list(range(n))
        order[3], order[4] = order[4], order[3]
        for k, seq in enumerate(order):
            t = T0_NS + int(span_s * 1e9 * k / (n - 1))
            payload = codec.to_json(_meas(seq))
            rec.write("sim/measurements", payload, t, None, k)
            sent.append(("sim/measurements", payload))
            if k == 10:
                rec.write("/_invalid/sim/measurements", b"{broken", t + 1, None, 0)
                sent.append(("sim/measurements", b"{broken"))
                rec.write("sim/debug", b'{"note":"outside the ICD"}', t + 2, None, 0)
                sent.append(("sim/debug", b'{"note":"outside the ICD"}'))
            if k % 5 == 0:
                payload = codec.to_json(_weights((0.5, 0.5), t=6e8 + k))
                rec.write("fsw/weights/chi2", payload, t + 3, None, k // 5)
                sent.append(("fsw/weights/chi2", payload))
    return sent


def test_iter_raw_gives_recorded_bytes_in_log_time_order(tmp_path):
    path = tmp_path / "r.mcap"
    sent = _recording(path)
    got = list(iter_raw(path))
    assert [(g.zenoh_topic, g.data) for g in got] == sent
    assert all(a.log_time_ns <= b.log_time_ns for a, b in zip(got, got[1:]))
    assert got[0].schema == codec.schema_name(m.Measurement)
    info = run_info(path)
    assert info.run_id == "orig-run" and info.config_text == SCENARIO and info.complete


def test_measurements_are_fed_in_sequence_order_with_malformed_kept_in_place(tmp_path):
    path = tmp_path / "r.mcap"
    _recording(path)
    stream, bad = recorded_measurement_stream(path)
    assert bad == 1
    seqs = [x.seq if isinstance(x, m.Measurement) else None for x in stream]
    # recorded order ... 4, 3, ... 10 (malformed) ...: sequence order, the malformed payload right after seq 10
    assert seqs[:11] == list(range(11)) and seqs[11] is None and seqs[12:] == list(range(11, 20))


# --------------------------------------------------------------------------------------------
# republication over Zenoh (loopback)
# --------------------------------------------------------------------------------------------


def _collect(sub: T.Subscriber, out: list, stop: threading.Event) -> None:
    while not stop.is_set():
        got = sub.recv(timeout=0.02)
        if got is not None:
            out.append(got)


@pytest.mark.parametrize("rate", [0.0, 2.0])
def test_republish_sends_every_payload_paced_and_drains(tmp_path, rate):
    path = tmp_path / "r.mcap"
    sent = _recording(path, n=20, span_s=1.0)
    port = T.free_tcp_ports(1)[0]
    listen = T.TransportConfig(listen=(f"tcp/127.0.0.1:{port}",))
    got: list[T.Received] = []
    stop = threading.Event()
    with T.open_session(listen) as session, T.Subscriber(session, "replayed", ("**",), decode=False, role="ground") as sub:
        worker = threading.Thread(target=_collect, args=(sub, got, stop), daemon=True)
        worker.start()
        try:
            t0 = time.monotonic()
            res = republish(path, "replayed", T.TransportConfig(connect=(f"tcp/127.0.0.1:{port}",)), rate=rate,
                            consumers=("ground",), consumer_timeout_s=10, drain_timeout_s=10)
            elapsed = time.monotonic() - t0
        finally:
            stop.set()
            worker.join(5)
    assert res.drained == {"ground": True}
    assert res.replayed == len(sent)
    data = [(g.topic, g.payload) for g in got if g.topic != "ground/status"]
    assert data == sent  # same bytes, same order
    # sequence numbers restart per topic under the new run id: no gaps
    assert sub.gaps == {}
    end = [g for g in got if g.topic == "ground/status"]
    assert len(end) == 1
    status = codec.from_json(m.RunStatus, end[0].payload)
    assert status.source == "replay" and status.state == "end-of-run" and status.run_id == "replayed"
    assert status.counts["sim/measurements"] == 21 and status.counts["fsw/weights/chi2"] == 4
    assert status.counts["sim/debug"] == 1 and status.counts["messages"] == len(sent)
    if rate == 2.0:  # 1 s recorded at twice the speed: at least 0.5 s of pacing
        assert res.elapsed_s >= 0.5 and elapsed >= 0.5
    else:
        assert res.elapsed_s < 5.0

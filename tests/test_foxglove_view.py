"""The Foxglove view (ground/foxglove): what each ICD message becomes, decoded with the schema the
view declares, and the shipped layout refers to channels a run has."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fsw.interface import codec, examples, messages as m
from ground.foxglove.plots import RESIDUAL_SCHEMA
from ground.foxglove.records import is_derived
from ground.foxglove.scene import SCENE_SCHEMA, TRANSFORM_SCHEMA, ellipsoid, quaternion_of
from ground.foxglove.view import FoxgloveView

decoder = pytest.importorskip("mcap_protobuf.decoder")
LAYOUT = Path(__file__).resolve().parents[1] / "docs" / "foxglove" / "navbank-layout.json"


class _Schema:
    def __init__(self, s):
        self.name, self.encoding, self.data, self.id = s.name, s.encoding, s.data, 1


def _decode(rec):
    return decoder.DecoderFactory().decoder_for("protobuf", _Schema(rec.schema))(rec.data)


def _example(name: str):
    return examples.examples()[name][0]


def test_truth_and_estimate_make_a_scene_in_metres():
    view = FoxgloveView(scene_every_s=3600.0)
    truth = _example("Truth")
    recs = view.convert("sim/truth", codec.to_json(truth), 10)
    assert [r.topic for r in recs] == ["/foxglove/transforms"] and recs[0].schema == TRANSFORM_SCHEMA
    tf = _decode(recs[0])
    assert tf.translation.x == pytest.approx(truth.position_km[0] * 1000.0)
    est = m.Estimate(t_s=truth.t_s, timestamp=truth.timestamp, filter="combined", position_km=truth.position_km,
                     velocity_km_s=truth.velocity_km_s, position_sigma_km=3.0, state_names=("x", "y", "z"),
                     state=truth.position_km, sigma=(1.0, 2.0, 0.5))
    recs = view.convert("fsw/estimate/combined", codec.to_json(est), 20)
    scene = [r for r in recs if r.topic == "/foxglove/scene"]
    assert len(scene) == 1 and scene[0].schema == SCENE_SCHEMA and scene[0].log_time_ns == 20
    ents = {e.id: e for e in _decode(scene[0]).entities}
    assert {"mars", "phobos", "deimos", "earth-direction", "spacecraft", "estimate/combined"} <= set(ents)
    assert ents["mars"].spheres[0].size.x == pytest.approx(2 * 3396.19e3)
    size = ents["estimate/combined"].spheres[0].size
    assert sorted([size.x, size.y, size.z]) == pytest.approx([3e3, 6e3, 12e3])  # 2·3σ per axis, in metres
    # the next estimate within the hour draws nothing; the position error plot needs truth at its epoch
    again = view.convert("fsw/estimate/combined", codec.to_json(est), 30)
    assert [r.topic for r in again] == ["/plot/position_error/combined"]


def test_the_earth_arrow_points_at_earth_as_de421_puts_it():
    from fsw.astro.ephemeris import default_ephemeris

    view = FoxgloveView(scene_every_s=3600.0)
    truth = _example("Truth")
    # hourly scenes for 25 days: the scene's tables of Earth's position (ten days each) are
    # made, and left, along the way
    for k, t in enumerate(truth.t_s + 3600.0 * np.arange(0, 25 * 24, 7)):
        est = m.Estimate(t_s=float(t), timestamp=truth.timestamp, filter="combined", position_km=truth.position_km,
                         velocity_km_s=truth.velocity_km_s, position_sigma_km=3.0, state_names=("x", "y", "z"),
                         state=truth.position_km, sigma=(1.0, 2.0, 0.5))
        scene = [r for r in view.convert("fsw/estimate/combined", codec.to_json(est), k) if r.topic == "/foxglove/scene"]
        (arrow,) = {e.id: e for e in _decode(scene[0]).entities}["earth-direction"].arrows
        q = arrow.pose.orientation
        w, v = q.w, np.array([q.x, q.y, q.z])
        x = np.array([1.0, 0.0, 0.0])
        pointed = x + 2.0 * w * np.cross(v, x) + 2.0 * np.cross(v, np.cross(v, x))  # +x rotated by q
        earth = default_ephemeris().position("earth", float(t), "mars")
        cos = float(pointed @ earth) / (np.linalg.norm(pointed) * np.linalg.norm(earth))
        assert np.arccos(min(cos, 1.0)) < 1e-7  # radians


def test_ellipsoid_orientation_maps_the_principal_axes():
    rng = np.random.default_rng(4)
    a = rng.normal(size=(3, 3))
    cov = a @ a.T
    sizes, q = ellipsoid(cov, n_sigma=1.0)
    x, y, z, w = q
    rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    np.testing.assert_allclose(rot @ np.diag((sizes / 2) ** 2) @ rot.T, cov, atol=1e-9)
    r = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    q = quaternion_of(r)
    assert q == pytest.approx((0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5)))


def test_events_become_foxglove_logs_once():
    view = FoxgloveView()
    fault = _example("FaultEvent")
    (rec,) = view.convert("sim/faults", codec.to_json(fault), 5)
    assert rec.topic == "/foxglove/log" and _decode(rec).message.startswith(f"fault {fault.fault_id}")
    rep = m.AnomalyReport(t_s=1.0, timestamp=m.Stamp(1, 0), flag=True, anomaly_class="optical-measurement",
                          confidence=0.9, declared_s=1.0, network="chi2", statistic=3.0, threshold=2.0)
    assert "ANOMALY declared by chi2" in _decode(view.convert("fsw/anomaly", codec.to_json(rep), 6)[0]).message
    assert view.convert("fsw/anomaly", codec.to_json(rep), 7) == []  # periodic repeats are not events
    running = m.RunStatus(t_s=1.0, timestamp=m.Stamp(1, 0), run_id="r", source="fsw", state="running")
    assert view.convert("fsw/status", codec.to_json(running), 8) == []


def test_residuals_become_flat_plot_channels():
    view = FoxgloveView()
    res = _example("Residuals")
    recs = view.convert("fsw/residuals", codec.to_json(res), 9)
    assert [r.topic for r in recs] == ["/plot/residuals/range/DSS_14"] and recs[0].schema == RESIDUAL_SCHEMA
    assert json.loads(recs[0].data) == {"t_s": res.samples[0].t_s, "radio": 1.09, "optical": 0.011}
    assert view.convert("fsw/residuals", b"{not json", 9) == [] and view.errors == 1


def test_layout_panels_are_configured_and_read_channels_a_run_has():
    layout = json.loads(LAYOUT.read_text())

    def leaves(node):
        return [node] if isinstance(node, str) else leaves(node["first"]) + leaves(node["second"])

    panels = leaves(layout["layout"])
    assert set(panels) == set(layout["configById"])
    topics = {p["value"].split(".")[0] for cfg in layout["configById"].values() for p in cfg.get("paths", [])}
    topics |= {t for cfg in layout["configById"].values() for t in cfg.get("topics", {})}
    topics.add(layout["configById"]["Log!events"]["topicToRender"])
    for t in topics:
        assert is_derived(t) or t.startswith("/fsw/weights/"), t

"""End to end: `navbank run --live` over real Zenoh, a real Foxglove WebSocket client, and the
run's MCAP read back — residual, B-plane and Foxglove well-known-schema channels validated."""

from __future__ import annotations

import asyncio
import json
import re
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader

websockets = pytest.importorskip("websockets")
mcap_protobuf = pytest.importorskip("mcap_protobuf.decoder")

pytestmark = pytest.mark.slow

TELEMETRY = "  telemetry: {residuals_every_s: 600.0, bplane_every_s: 21600.0}\n"
SUBPROTOCOL = "foxglove.sdk.v1"
WANTED = ("/fsw/weights/", "/foxglove/scene")


async def _watch(url: str, deadline: float) -> dict[str, int]:
    """Connect, subscribe to the weights and scene channels as they are advertised, count what arrives."""
    got: dict[str, int] = {}
    while True:
        try:
            ws = await websockets.connect(url, subprotocols=[SUBPROTOCOL], max_size=None, open_timeout=2)
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.05)
    topic_of: dict[int, str] = {}
    next_id = 1
    async with ws:
        while time.monotonic() < deadline and not (any(t.startswith(WANTED[0]) for t in got) and WANTED[1] in got):
            try:
                frame = await asyncio.wait_for(ws.recv(), timeout=max(0.1, deadline - time.monotonic()))
            except (asyncio.TimeoutError, websockets.ConnectionClosed):
                break
            if isinstance(frame, str):
                op = json.loads(frame)
                if op.get("op") == "advertise":
                    subs = []
                    for ch in op["channels"]:
                        if ch["topic"].startswith(WANTED):
                            subs.append({"id": next_id, "channelId": ch["id"]})
                            topic_of[next_id] = ch["topic"]
                            next_id += 1
                    if subs:
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
            elif frame[0] == 0x01:  # message data: opcode, subscription id, log time, payload
                sub_id, _log_time = struct.unpack_from("<IQ", frame, 1)
                topic = topic_of.get(sub_id, "?")
                got[topic] = got.get(topic, 0) + 1
    return got


@pytest.fixture(scope="module")
def live_run(tmp_path_factory, short_e2e_yaml):
    d = tmp_path_factory.mktemp("live")
    scen = d / "short.yaml"
    scen.write_text(short_e2e_yaml + TELEMETRY)
    out = d / "out"
    proc = subprocess.Popen([sys.executable, "-m", "tools.cli", "run", "--scenario", str(scen), "--out", str(out),
                             "--quiet", "--live", "--live-port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    url = None
    err_lines: list[str] = []
    deadline = time.monotonic() + 60
    assert proc.stderr is not None
    while url is None and time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        err_lines.append(line)
        found = re.search(r"live view on (ws://\S+)", line)
        url = found.group(1) if found else None
    rest: list[str] = []
    drain = threading.Thread(target=lambda: rest.extend(proc.stderr), daemon=True)  # type: ignore[arg-type]
    drain.start()
    received: dict[str, int] = {}
    if url is not None:
        received = asyncio.run(_watch(url, time.monotonic() + 90))
    stdout, _ = proc.communicate(timeout=300)
    drain.join(timeout=5)
    return proc.returncode, "".join(err_lines + rest) + stdout, out, url, received


def test_live_view_serves_weights_and_scene(live_run):
    code, output, _, url, received = live_run
    assert code == 0, output[-3000:]
    assert url is not None and url.startswith("ws://127.0.0.1:"), output[-3000:]
    assert any(t.startswith("/fsw/weights/") and n > 0 for t, n in received.items()), received
    assert received.get("/foxglove/scene", 0) > 0, received


def _channels(path: Path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        return summary


def test_recording_has_residual_bplane_and_foxglove_channels_that_validate(live_run):
    code, output, out, _, _ = live_run
    assert code == 0, output[-3000:]
    path = out / "run.mcap"
    summary = _channels(path)
    by_topic = {c.topic: c for c in summary.channels.values()}
    need = {"/fsw/residuals", "/fsw/bplane/combined", "/fsw/bplane/best", "/foxglove/scene", "/foxglove/transforms",
            "/foxglove/log", "/plot/bplane/combined"}
    assert need <= set(by_topic), sorted(by_topic)
    assert summary.schemas[by_topic["/foxglove/scene"].schema_id].name == "foxglove.SceneUpdate"
    assert summary.schemas[by_topic["/foxglove/transforms"].schema_id].name == "foxglove.FrameTransform"
    assert summary.schemas[by_topic["/foxglove/log"].schema_id].name == "foxglove.Log"
    validators = {}
    decoded: dict[str, list] = {}
    factory = mcap_protobuf.DecoderFactory()
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if channel.topic not in need:
                continue
            if channel.message_encoding == "json":
                v = validators.get(channel.id)
                if v is None:
                    v = validators[channel.id] = jsonschema.Draft202012Validator(json.loads(schema.data))
                obj = json.loads(message.data)
                v.validate(obj)
            else:
                assert channel.message_encoding == "protobuf" and schema.encoding == "protobuf"
                obj = factory.decoder_for("protobuf", schema)(message.data)
            decoded.setdefault(channel.topic, []).append((message.log_time, message.publish_time, obj))
    # residuals: every filter, every measurement the FSW filtered
    res = [o for _, _, o in decoded["/fsw/residuals"]]
    seqs = [s["seq"] for r in res for s in r["samples"]]
    assert len(seqs) > 2000 and len(seqs) == len(set(seqs))
    assert all(len(s["normalised"]) == len(r["filters"]) == 3 for r in res for s in r["samples"])
    # B-plane: Mars approach, B-plane offset of a few thousand km
    bp = [o for _, _, o in decoded["/fsw/bplane/combined"]]
    assert bp and all(1000.0 < abs(complex(b["b_dot_t_km"], b["b_dot_r_km"])) < 50000.0 for b in bp)
    # the scene is in metres: Mars is a sphere of its diameter, the spacecraft ~1e9 m away
    scenes = [o for _, _, o in decoded["/foxglove/scene"]]
    mars = [e for s in scenes for e in s.entities if e.id == "mars"]
    assert mars and abs(mars[0].spheres[0].size.x - 2 * 3396.19e3) < 1.0
    assert {e.id for s in scenes for e in s.entities} >= {"phobos", "deimos", "earth-direction", "estimate/combined"}
    assert any(e.id.startswith("truth-path/") and len(e.lines[0].points) >= 2 for s in scenes for e in s.entities)
    tf = decoded["/foxglove/transforms"][0][2]
    assert tf.parent_frame_id == "mars" and 1e8 < abs(tf.translation.x) + abs(tf.translation.y) + abs(tf.translation.z)
    logs = [o for _, _, o in decoded["/foxglove/log"]]
    assert any(log.message.startswith("fault ") for log in logs), [log.message for log in logs]
    assert any(log.message == "fsw end-of-run" for log in logs), [log.message for log in logs]
    # mission time as log_time: ICD channels' log_time is their own timestamp; the file spans the mission
    assert all(lt == pt for lt, pt, _ in decoded["/fsw/residuals"])
    span_days = (summary.statistics.message_end_time - summary.statistics.message_start_time) / 86400e9
    assert 3.5 < span_days < 4.5

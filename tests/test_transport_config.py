"""Session configuration: loopback defaults, failed connects, mesh layout."""

from __future__ import annotations

import json
import time

import pytest

from fsw import transport as T


def test_defaults_are_loopback_peer_without_multicast():
    zc = T.zenoh_config(T.TransportConfig())
    assert json.loads(zc.get_json("mode")) == "peer"
    assert json.loads(zc.get_json("scouting/multicast/enabled")) is False
    assert json.loads(zc.get_json("listen/endpoints")) == ["tcp/127.0.0.1:0"]
    assert json.loads(zc.get_json("connect/endpoints")) == []


def test_connect_sets_timeout_and_exit_on_failure():
    zc = T.zenoh_config(T.TransportConfig(connect=("tcp/127.0.0.1:7447",), connect_timeout_s=2.5))
    assert json.loads(zc.get_json("connect/timeout_ms")) == 2500
    assert json.loads(zc.get_json("connect/exit_on_failure")) is True


def test_failed_connect_raises_within_the_timeout():
    (port,) = T.free_tcp_ports(1)
    t0 = time.monotonic()
    with pytest.raises(T.TransportError, match="cannot open"):
        T.open_session(T.TransportConfig(connect=(f"tcp/127.0.0.1:{port}",), connect_timeout_s=0.5))
    assert time.monotonic() - t0 < 5.0


def test_bad_endpoints_and_client_without_router_are_rejected():
    with pytest.raises(ValueError, match="endpoint"):
        T.TransportConfig(listen=("127.0.0.1:7447",))
    with pytest.raises(ValueError, match="client"):
        T.TransportConfig(mode="client")


def test_config_file_is_the_base_and_fields_override(tmp_path):
    f = tmp_path / "z.json5"
    f.write_text('{ mode: "client", scouting: { multicast: { enabled: true } }, timestamping: { enabled: { peer: true } } }')
    zc = T.zenoh_config(T.TransportConfig(config_file=str(f)))
    assert json.loads(zc.get_json("mode")) == "peer"
    assert json.loads(zc.get_json("scouting/multicast/enabled")) is False
    assert "true" in zc.get_json("timestamping/enabled")  # kept from the file
    with pytest.raises(T.TransportError):
        T.zenoh_config(T.TransportConfig(config_file=str(tmp_path / "missing.json5")))


def test_mesh_connects_each_role_to_the_earlier_ones():
    cfgs = T.mesh_configs(["ground", "fsw", "sim"], ports=[7001, 7002, 7003])
    assert cfgs["ground"].listen == ("tcp/127.0.0.1:7001",) and cfgs["ground"].connect == ()
    assert cfgs["fsw"].connect == ("tcp/127.0.0.1:7001",)
    assert cfgs["sim"].connect == ("tcp/127.0.0.1:7001", "tcp/127.0.0.1:7002")
    assert len(set(T.free_tcp_ports(3))) == 3


def test_publisher_rejects_wrong_types_and_unknown_topics():
    from fsw.interface import messages as m

    with T.open_session(T.TransportConfig()) as s:
        with pytest.raises(ValueError, match="not in the ICD"):
            T.Publisher(s, "r", "sim/bogus")
        with pytest.raises(ValueError, match="carries"):
            T.Publisher(s, "r", "sim/measurements", m.Truth)
        with T.Publisher(s, "r", "sim/status") as pub:
            with pytest.raises(TypeError):
                pub.put(m.Telecommand(id="a", command="status"))
    with pytest.raises(ValueError, match="'/'"):
        T.end_of_run_counts([], **{"a/b": 1})

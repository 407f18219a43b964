"""The ICD: round trips, generated schemas, strict rejection of malformed payloads."""

import json
import math

import jsonschema
import numpy as np
import pytest

from fsw.interface import codec, messages, topics
from fsw.interface.examples import examples

EXAMPLES = [(name, ex) for name, exs in examples().items() for ex in exs]


def test_every_type_has_an_example():
    assert set(examples()) == set(messages.MESSAGE_TYPES)


@pytest.mark.parametrize("name,msg", EXAMPLES, ids=[f"{n}-{i}" for i, (n, _) in enumerate(EXAMPLES)])
def test_round_trip_is_lossless(name, msg):
    cls = messages.MESSAGE_TYPES[name]
    payload = codec.to_json(msg)
    back = codec.from_json(cls, payload)
    assert back == msg
    assert codec.to_json(back) == payload


@pytest.mark.parametrize("name,msg", EXAMPLES, ids=[f"{n}-{i}" for i, (n, _) in enumerate(EXAMPLES)])
def test_schema_is_valid_and_validates_example(name, msg):
    cls = messages.MESSAGE_TYPES[name]
    schema = codec.schema_of(cls)
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.validate(json.loads(codec.to_json(msg)), schema)


def test_floats_round_trip_bit_exactly():
    x = 0.1 + 0.2
    m = messages.Measurement(seq=5, t_s=x * 1e9, timestamp=messages.Stamp(sec=1, nsec=2), kind="range",
                             source="DSS-14", value=(math.pi * 1e8,), sigma=(1e-3 / 3,))
    back = codec.from_json(messages.Measurement, codec.to_json(m))
    assert back.t_s == m.t_s and back.value == m.value and back.sigma == m.sigma


def _good_measurement() -> dict:
    return json.loads(codec.to_json(examples()["Measurement"][2]))


@pytest.mark.parametrize(
    "mutate,where",
    [
        (lambda d: d.update(seq="7"), "seq"),
        (lambda d: d.update(seq=-1), "seq"),
        (lambda d: d.update(value=[1.0]), ""),
        (lambda d: d.update(value=[1.0, 2.0, 3.0], sigma=[1.0, 1.0, 1.0]), ""),
        (lambda d: d.update(kind="lidar"), "kind"),
        (lambda d: d.update(attitude_q=[1.0, 0.0, 0.0]), "attitude_q"),
        (lambda d: d.update(extra=1), "extra"),
        (lambda d: d.pop("t_s"), "t_s"),
        (lambda d: d.update(value=[1e400, 2.0]), ""),  # serialised as Infinity: rejected by the parser
        (lambda d: d.update(sigma=[0.0, 1.0]), ""),
        (lambda d: d.update(timestamp={"sec": 1}), "timestamp.nsec"),
        (lambda d: d.update(value=[True, 2.0]), "value[0]"),
    ],
)
def test_malformed_measurements_are_rejected_with_the_typed_error(mutate, where):
    data = _good_measurement()
    mutate(data)
    text = json.dumps(data)
    with pytest.raises(codec.ICDError) as info:
        codec.from_json(messages.Measurement, text)
    assert info.value.type_name == "Measurement"
    assert info.value.path == where


@pytest.mark.parametrize(
    "fields,message",
    [
        ({"sigma": (1.0, 0.0)}, "sigma components must be > 0"),
        ({"sigma": (1.0, -2.0)}, "sigma components must be > 0"),
        ({"sigma": (1.0,)}, "sigma has 1 components"),
        ({"attitude_q": None}, "needs attitude_q"),
        ({"kind": "range", "value": (1.0,), "sigma": (-1.0,), "attitude_q": None}, "sigma components must be > 0"),
        ({"kind": "range", "value": (1.0, 2.0)}, "has 1 component"),
    ],
)
def test_measurement_construction_checks_each_component_and_required_field(fields, message):
    good = examples()["Measurement"][2]
    kwargs = {f: getattr(good, f) for f in good.__slots__} | fields
    with pytest.raises(ValueError, match=message):
        messages.Measurement(**kwargs)
    # a NaN sigma is the codec's to refuse (non-finite), not a "non-positive" one here
    messages.Measurement(**({f: getattr(good, f) for f in good.__slots__} | {"sigma": (1.0, float("nan"))}))


@pytest.mark.parametrize(
    "payload",
    [
        b"",
        b"\xff\xfe\x00garbage",
        b'{"seq": 1',
        b"[1, 2, 3]",
        b"null",
        codec.to_json(examples()["Measurement"][2]).replace(b"501.25", b"NaN"),
        codec.to_json(examples()["Measurement"][2]).replace(b"501.25", b"Infinity"),
        b"[" * 100000,
    ],
)
def test_garbage_payloads_are_rejected_with_the_typed_error(payload):
    with pytest.raises(codec.ICDError):
        codec.from_json(messages.Measurement, payload)


def test_encoding_refuses_non_finite_numbers():
    bad = messages.Measurement(seq=0, t_s=float("nan"), timestamp=messages.Stamp(sec=0, nsec=0), kind="range",
                               source="DSS-14", value=(1.0,), sigma=(1.0,))
    with pytest.raises(codec.ICDError):
        codec.to_json(bad)


def test_telecommand_requires_its_arguments():
    with pytest.raises(codec.ICDError):
        codec.from_json(messages.Telecommand, b'{"id": "x", "command": "set-param", "network": "chi2"}')
    with pytest.raises(codec.ICDError):
        codec.from_json(messages.Telecommand, b'{"id": "x", "command": "self-destruct"}')


def test_stamp_from_unix():
    s = messages.Stamp.from_unix(1_543_233_531.999_999_999_9)
    assert 0 <= s.nsec < 1_000_000_000
    assert abs(s.to_unix() - 1_543_233_532.0) < 1e-6


def test_stamp_from_unix_is_floor_and_rounded_nanoseconds():
    """Whole seconds by floor division, nanoseconds rounded half to even with the carry into the
    seconds, negative times clamped to 0, ints whatever float type comes in (numpy's too)."""
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.uniform(0.0, 2e9, 20_000), rng.uniform(1.7e9, 1.8e9, 20_000),
                             rng.uniform(-5.0, 5.0, 2_000), np.arange(2_000) + 0.9999999999,
                             np.arange(2_000) + 0.5e-9, [0.0, 1.0, 2.5, 1e-10, -0.0]])
    for u in values.tolist():
        sec = int(u // 1)
        nsec = int(round((u - sec) * 1e9))
        if nsec >= 1_000_000_000:
            sec, nsec = sec + 1, nsec - 1_000_000_000
        for given in (u, np.float64(u)):
            s = messages.Stamp.from_unix(given)
            assert (s.sec, s.nsec) == (max(sec, 0), nsec)
            assert type(s.sec) is int and type(s.nsec) is int
    carried = messages.Stamp.from_unix(41.9999999999)
    assert (carried.sec, carried.nsec) == (42, 0)


def test_schema_names_and_lookup():
    for name, cls in messages.MESSAGE_TYPES.items():
        assert codec.type_by_name(codec.schema_name(cls)) is cls
        assert codec.type_by_name(name) is cls
    with pytest.raises(codec.ICDError):
        codec.type_by_name("navbank.Nope/v1")


def test_topics_map_to_types_and_keys():
    assert topics.type_of_topic("fsw/weights/chi2") is messages.FilterWeights
    assert topics.type_of_topic("/sim/measurements") is messages.Measurement
    assert topics.type_of_topic("fsw/estimate/best") is messages.Estimate
    with pytest.raises(KeyError):
        topics.type_of_topic("fsw/weights/")
    k = topics.key("run-7", "fsw/anomaly")
    assert k == "navbank/run-7/fsw/anomaly"
    assert topics.topic_of_key(k) == ("run-7", "fsw/anomaly")
    assert topics.mcap_topic("fsw/anomaly") == "/fsw/anomaly"
    for bad in ("", "a/b", "*", "x" * 65):
        with pytest.raises(ValueError):
            topics.check_run_id(bad)

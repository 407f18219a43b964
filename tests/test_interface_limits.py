"""Size limits of the ICD: every message the decoder accepts is bounded, so decoding any payload
takes bounded time; and whatever bytes arrive, decoding ends in a message or an ICDError."""

from __future__ import annotations

import json

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw.interface import codec, messages as m
from fsw.interface.examples import examples

GOOD = {"seq": 1, "t_s": 6.0e8, "timestamp": {"sec": 1, "nsec": 0}, "kind": "generic-linear", "source": "x",
        "value": [1.0], "sigma": [1.0]}


def _payload(**changes) -> bytes:
    return json.dumps({**GOOD, **changes}).encode()


def _rejected(cls, payload: bytes) -> str:
    """The error of a refused payload. Its wording says at which check it stopped: the byte
    count before parsing, an element count before any element is decoded."""
    try:
        codec.from_json(cls, payload)
    except codec.ICDError as exc:
        return str(exc)
    raise AssertionError("decoded")


def test_a_payload_over_the_byte_limit_is_refused_unparsed():
    big = _payload(value=[1.0] * 300_000, sigma=[1.0] * 300_000)  # ~1.8 MB: the 10^6-element attack's kind
    assert len(big) > codec.MAX_PAYLOAD_BYTES
    assert "bytes" in _rejected(m.Measurement, big)


def test_oversized_lists_are_refused_before_their_elements_are_looked_at():
    n = m.MAX_COMPONENTS + 1
    assert "at most 64 elements" in _rejected(m.Measurement, _payload(value=[1.0] * n, sigma=[1.0] * n))
    many = _payload(value=[1.0] * 100_000, sigma=[1.0])  # under the byte limit
    assert len(many) < codec.MAX_PAYLOAD_BYTES
    assert "value: expected at most 64 elements, got 100000" in _rejected(m.Measurement, many)


def test_oversized_strings_and_mappings_are_refused():
    assert "source" in _rejected(m.Measurement, _payload(source="x" * (m.NAME_CHARS + 1)))
    status = {"t_s": 0.0, "timestamp": {"sec": 0, "nsec": 0}, "run_id": "r", "source": "sim", "state": "running",
              "counts": {f"c{i}": i for i in range(m.MAX_COUNTERS + 1)}}
    assert "counts" in _rejected(m.RunStatus, json.dumps(status).encode())
    cmd = {"id": "i" * (m.NAME_CHARS + 1), "command": "status"}
    assert "id" in _rejected(m.Telecommand, json.dumps(cmd).encode())


def test_every_example_message_is_within_the_limits():
    for msgs in examples().values():
        for msg in msgs:
            assert codec.from_json(type(msg), codec.to_json(msg)) == msg


def test_the_limits_are_in_the_json_schemas():
    meas = codec.schema_of(m.Measurement)["properties"]
    assert meas["value"]["maxItems"] == m.MAX_COMPONENTS and meas["source"]["maxLength"] == m.NAME_CHARS
    status = codec.schema_of(m.RunStatus)["properties"]["counts"]
    assert status["maxProperties"] == m.MAX_COUNTERS and status["propertyNames"] == {"maxLength": m.NAME_CHARS}
    est = codec.schema_of(m.Estimate)["properties"]["covariance"]["anyOf"][0]
    assert est["maxItems"] == m.MAX_STATES and est["items"]["maxItems"] == m.MAX_STATES


_json = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=6) | st.dictionaries(st.text(max_size=12), inner, max_size=6),
    max_leaves=30,
)


@settings(max_examples=400, deadline=None)
@given(st.one_of(
    st.binary(max_size=200),
    _json.map(lambda v: json.dumps(v).encode()),
    st.dictionaries(st.sampled_from(sorted(GOOD) + ["extra"]), _json, max_size=9).map(
        lambda d: json.dumps({**GOOD, **d}).encode()),
))
def test_any_payload_decodes_or_is_an_icd_error(payload):
    for cls in (m.Measurement, m.Telecommand, m.RunStatus):
        try:
            codec.from_json(cls, payload)
        except codec.ICDError:
            pass

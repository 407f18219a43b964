"""The compiled codec (msgspec, generated from the ICD declarations) against the reference one
(``fsw.interface.typed``): whatever the compiled decoder accepts, the reference accepts with an
equal message; every ICD type takes the compiled path; the compiled encoder writes the same JSON
values and still refuses non-finite numbers."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsw.interface import codec, compiled, messages as m
from fsw.interface.examples import examples
from fsw.interface.typed import DecodeError, decode, encode

EXAMPLES = [(type(msg), msg) for msgs in examples().values() for msg in msgs]


def _reference(cls: type, payload: bytes) -> Any:
    """The reference decoder's verdict: the message, or the error it raises (NaN and Infinity
    tokens are not JSON: refused as the codec refuses them)."""
    try:
        return decode(cls, json.loads(payload, parse_constant=_not_json))
    except (DecodeError, ValueError, RecursionError, OverflowError) as exc:
        return exc


def _not_json(token: str) -> Any:
    raise ValueError(token)


def test_every_icd_type_has_a_compiled_decoder():
    missing = [name for name, cls in m.MESSAGE_TYPES.items() if compiled.decoder(cls) is None]
    assert missing == []


@pytest.mark.parametrize("cls,msg", EXAMPLES, ids=[f"{c.__name__}{i}" for i, (c, _) in enumerate(EXAMPLES)])
def test_examples_take_the_compiled_path_both_ways(cls, msg):
    reference_bytes = json.dumps(encode(msg), separators=(",", ":"), allow_nan=False).encode()
    fast = compiled.decoder(cls)
    assert fast is not None
    got = fast(reference_bytes)
    assert got == msg and type(got) is cls
    out = compiled.encode(msg)
    assert json.loads(out) == json.loads(reference_bytes)


_json = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=6) | st.dictionaries(st.text(max_size=12), inner, max_size=6),
    max_leaves=30,
)


def _paths(value: Any, path: tuple = ()) -> list[tuple]:
    out = [path]
    if isinstance(value, dict):
        for k, v in value.items():
            out += _paths(v, path + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            out += _paths(v, path + (i,))
    return out


def _replace(value: Any, path: tuple, new: Any) -> Any:
    if not path:
        return new
    head, rest = path[0], path[1:]
    if isinstance(value, dict):
        return {**value, head: _replace(value[head], rest, new)}
    return [_replace(v, rest, new) if i == head else v for i, v in enumerate(value)]


@st.composite
def _mutated(draw) -> tuple[type, bytes]:
    """An example message's JSON with one value replaced, a key added or removed, or a number nudged."""
    cls, msg = draw(st.sampled_from(EXAMPLES))
    data = encode(msg)
    path = draw(st.sampled_from(_paths(data)))
    how = draw(st.sampled_from(["replace", "number", "drop", "extra", "same"]))
    if how == "replace":
        data = _replace(data, path, draw(_json))
    elif how == "number":
        data = _replace(data, path, draw(st.integers(-2**70, 2**70) | st.floats(allow_nan=False)
                                         | st.sampled_from([0, -1, 1.0, 7.0, 1e9, -1e-300, 2**63, True])))
    elif how == "drop" and path:
        parent = _get(data, path[:-1])
        if isinstance(parent, dict):
            data = _replace(data, path[:-1], {k: v for k, v in parent.items() if k != path[-1]})
    elif how == "extra":
        parent = _get(data, path)
        if isinstance(parent, dict):
            data = _replace(data, path, {**parent, draw(st.text(max_size=8)): draw(_json)})
        elif isinstance(parent, list):
            data = _replace(data, path, parent + [draw(_json)])
    text = json.dumps(data)
    if draw(st.booleans()):
        text = text.replace("1.0", draw(st.sampled_from(["NaN", "Infinity", "1e999", "1.0"])), 1)
    return cls, text.encode()


def _get(value: Any, path: tuple) -> Any:
    for k in path:
        value = value[k]
    return value


@settings(max_examples=1500, deadline=None)
@given(_mutated())
def test_what_the_compiled_decoder_accepts_the_reference_accepts_equally(case):
    cls, payload = case
    fast = compiled.decoder(cls)
    assert fast is not None
    try:
        got = fast(payload)
    except compiled.Refused:
        return  # the reference decoder judges it (codec.from_json), and names the key path
    want = _reference(cls, payload)
    assert not isinstance(want, Exception), f"compiled accepted what the reference refuses: {want}"
    assert got == want and type(got) is type(want)


@settings(max_examples=500, deadline=None)
@given(_mutated())
def test_codec_errors_are_the_reference_errors(case):
    cls, payload = case
    want = _reference(cls, payload)
    try:
        got = codec.from_json(cls, payload)
    except codec.ICDError as exc:
        if isinstance(want, DecodeError):
            assert (exc.path, exc.expected, exc.got) == (want.path, want.expected, want.got)
        return
    assert got == want


def test_non_finite_floats_are_refused_by_encoding_even_beside_nulls():
    base = m.Measurement(seq=0, t_s=1.0, timestamp=m.Stamp(sec=0, nsec=0), kind="range", source="null",
                         value=(1.0,), sigma=(1.0,))  # attitude_q and count_time_s: two nulls
    assert json.loads(codec.to_json(base))["source"] == "null"
    for bad in (math.nan, math.inf, -math.inf):
        msg = m.Measurement(seq=0, t_s=1.0, timestamp=m.Stamp(sec=0, nsec=0), kind="range", source="DSS-14",
                            value=(bad,), sigma=(1.0,))
        with pytest.raises(compiled.Refused):
            compiled.encode(msg)
        with pytest.raises(codec.ICDError):
            codec.to_json(msg)
    nested = m.CommandRecord(t_s=1.0, timestamp=m.Stamp(sec=0, nsec=0), taken=0, telecommand=None,
                             reply=m.TelecommandReply(id="x", ok=False, status={"v": math.nan}))
    with pytest.raises(codec.ICDError):
        codec.to_json(nested)


def test_numpy_scalars_encode_as_their_values():
    msg = m.BudgetReport(frame=0, t_s=np.float64(2.5), timestamp=m.Stamp(sec=0, nsec=0), mode="cpu",
                         used=np.float64(0.1), budget=1.0, utilisation=0.1, processed=1, deferred=0, backlog=0,
                         overruns=0)
    assert json.loads(codec.to_json(msg))["t_s"] == 2.5
    bad = m.BudgetReport(frame=0, t_s=np.float64("nan"), timestamp=m.Stamp(sec=0, nsec=0), mode="cpu",
                         used=0.1, budget=1.0, utilisation=0.1, processed=1, deferred=0, backlog=0, overruns=0)
    with pytest.raises(codec.ICDError):
        codec.to_json(bad)

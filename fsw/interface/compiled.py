"""Compiled JSON decoding and encoding of the ICD messages (msgspec), generated from their declarations.

The same ``spec(...)`` declarations that :mod:`fsw.interface.typed` reads are turned into msgspec
``Struct`` types carrying every constraint as ``msgspec.Meta``: types, ranges, fixed shapes, the
size limits of lists, mappings and strings, unknown keys refused. msgspec checks all of it in C
while it parses, then a generated builder makes the message's frozen dataclass from the Struct
(running its ``__post_init__`` cross-field rules). A payload this decoder accepts is one the
reference decoder (``typed.decode``) accepts with the same result; anything it refuses is handed
back (:class:`Refused`) so the caller can run the reference decoder for its error, which names
the key path. The fast path is never the judge of a refusal, only of acceptance.

The encoder writes the dataclass with msgspec as well (field order, tuples as arrays, no
envelope — the same JSON as ``json.dumps(typed.encode(msg))``, though a float's exponent is
written ``1e16`` rather than ``1e+16`` and non-ASCII characters are not escaped). msgspec writes
a non-finite float as ``null`` without complaint, so an encoding holding more ``null``\\s than the
message has ``None`` values is refused too (:class:`Refused`) and the caller's reference encoder
raises.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from functools import lru_cache
from typing import Annotated, Any, Callable, Literal, Optional, get_args, get_origin

import msgspec

from fsw.interface.typed import fields_of

_MISSING = dataclasses.MISSING


class Refused(Exception):
    """The compiled path does not accept this payload or message: use the reference path."""


class _Unsupported(Exception):
    """A declaration the compiled path does not mirror (the reference path handles it alone)."""


def _optional(tp: Any) -> tuple[bool, Any]:
    if get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in get_args(tp) if a is not type(None)]
        if len(args) == 1 and len(get_args(tp)) == 2:
            return True, args[0]
    return False, tp


def _meta(**kw: Any) -> msgspec.Meta | None:
    kw = {k: v for k, v in kw.items() if v is not None}
    return msgspec.Meta(**kw) if kw else None


def _annotate(tp: Any, meta: msgspec.Meta | None) -> Any:
    return tp if meta is None else Annotated[tp, meta]


def _ann(tp: Any, meta: dict, dim: int = 0) -> Any:
    """The msgspec type of a field of type ``tp`` declared with ``meta`` (as typed._decode_value reads it)."""
    optional, inner = _optional(tp)
    if optional:
        return Optional[_ann(inner, meta, dim)]
    if tp is Any or hasattr(tp, "_typed_decode"):
        raise _Unsupported(repr(tp))
    if tp is bool:
        return bool
    if tp in (int, float):
        return _annotate(tp, _meta(ge=meta.get("ge"), gt=meta.get("gt"), le=meta.get("le"), lt=meta.get("lt")))
    if tp is str:
        return _annotate(str, _meta(max_length=meta.get("max_length")))
    origin = get_origin(tp)
    if origin is Literal:
        choices = get_args(tp)
        if not all(isinstance(c, str) for c in choices):
            raise _Unsupported(repr(tp))  # typed tells bool from int choices; keep that to it
        return tp
    if origin is tuple:
        args = get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            elem = args[0]
            elem_t = _struct(elem) if _is_dataclass(elem) else _ann(elem, meta, dim + 1)
            shape = meta.get("shape")
            fixed = shape[dim] if shape is not None and dim < len(shape) else None
            most = meta.get("max_items")
            if fixed is not None:
                most = fixed if most is None else min(most, fixed)
            return _annotate(tuple[elem_t, ...], _meta(min_length=fixed, max_length=most))  # type: ignore[valid-type]
        return tuple.__class_getitem__(tuple(_ann(a, {}, dim + 1) for a in args))
    if origin is dict:
        ktype, vtype = get_args(tp)
        if ktype is not str:
            raise _Unsupported(repr(tp))
        key_t = _annotate(str, _meta(max_length=meta.get("max_length")))
        mapping = dict.__class_getitem__((key_t, _ann(vtype, meta, dim)))
        return _annotate(mapping, _meta(max_length=meta.get("max_items")))
    if _is_dataclass(tp):
        return _struct(tp)
    raise _Unsupported(repr(tp))


def _is_dataclass(tp: Any) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


@lru_cache(maxsize=None)
def _struct(cls: type) -> type:
    """The msgspec Struct mirroring dataclass ``cls`` (same field names, constraints as Meta)."""
    if hasattr(cls, "_typed_decode"):
        raise _Unsupported(cls.__name__)
    fields: list[tuple[str, Any, Any] | tuple[str, Any]] = []
    for f, tp in fields_of(cls):
        if not f.init:
            raise _Unsupported(f"{cls.__name__}.{f.name}")
        t = _ann(tp, dict(f.metadata))
        if f.default is not _MISSING:
            fields.append((f.name, t, f.default))
        elif f.default_factory is not _MISSING:
            fields.append((f.name, t, msgspec.field(default_factory=f.default_factory)))
        else:
            fields.append((f.name, t))
    return msgspec.defstruct(f"{cls.__name__}Wire", fields, kw_only=True, forbid_unknown_fields=True)


def _value_builder(tp: Any, env: dict[str, Any]) -> Callable[[str], str] | None:
    """Source text turning the Struct value of a field of type ``tp`` into the dataclass value
    (None: the value is used as it is)."""
    optional, inner = _optional(tp)
    if optional:
        conv = _value_builder(inner, env)
        if conv is None:
            return None
        return lambda v: f"(None if {v} is None else {conv(v)})"
    if _is_dataclass(tp):
        name = f"_b_{tp.__name__}"
        env[name] = _builder(tp)
        return lambda v: f"{name}({v})"
    if get_origin(tp) is tuple:
        args = get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis and _is_dataclass(args[0]):
            name = f"_b_{args[0].__name__}"
            env[name] = _builder(args[0])
            return lambda v: f"tuple(map({name}, {v}))"
        if any(_value_builder(a, {}) is not None for a in args if a is not Ellipsis):
            raise _Unsupported(repr(tp))
    if get_origin(tp) is dict and _value_builder(get_args(tp)[1], {}) is not None:
        raise _Unsupported(repr(tp))
    return None


@lru_cache(maxsize=None)
def _builder(cls: type) -> Callable[[Any], Any]:
    """A generated function making a ``cls`` instance from its Struct (positional arguments)."""
    env: dict[str, Any] = {"_cls": cls}
    args = []
    for f, tp in fields_of(cls):
        conv = _value_builder(tp, env)
        value = f"s.{f.name}"
        args.append(value if conv is None else conv(value))
    src = f"def build(s):\n    return _cls({', '.join(args)})\n"
    exec(src, env)  # generated from the declaration: one attribute read per field, no loop
    return typing.cast(Callable[[Any], Any], env["build"])


@lru_cache(maxsize=None)
def decoder(cls: type) -> Callable[[Any], Any] | None:
    """Strict compiled decoding of JSON bytes/str into a ``cls`` instance, or None if ``cls`` has a
    declaration only the reference decoder handles. The function raises :class:`Refused` for
    anything the declaration does not accept."""
    try:
        struct = _struct(cls)
        build = _builder(cls)
    except _Unsupported:
        return None
    parse: Callable[[Any], Any] = msgspec.json.Decoder(struct).decode

    def decode(payload: Any) -> Any:
        try:
            return build(parse(payload))
        except (msgspec.DecodeError, ValueError, TypeError, RecursionError):
            # msgspec.ValidationError is a DecodeError; ValueError/TypeError are __post_init__'s
            raise Refused from None

    return decode


def _none_counter(cls: type) -> Callable[[Any], int]:
    """A function counting the ``None`` values a ``cls`` instance holds (each encodes as ``null``)."""
    parts: list[Callable[[Any], int]] = []
    for f, tp in fields_of(cls):
        optional, inner = _optional(tp)
        if optional:
            parts.append(_count_optional(f.name, _none_counter_cached(inner) if _is_dataclass(inner) else None))
        elif _is_dataclass(tp):
            parts.append(_count_nested(f.name, _none_counter_cached(tp)))
        elif get_origin(tp) is tuple and len(get_args(tp)) == 2 and _is_dataclass(get_args(tp)[0]):
            parts.append(_count_each(f.name, _none_counter_cached(get_args(tp)[0])))

    def count(msg: Any) -> int:
        return sum(p(msg) for p in parts)

    return count


def _count_optional(name: str, inner: Callable[[Any], int] | None) -> Callable[[Any], int]:
    def count(msg: Any) -> int:
        value = getattr(msg, name)
        if value is None:
            return 1
        return 0 if inner is None else inner(value)

    return count


def _count_nested(name: str, inner: Callable[[Any], int]) -> Callable[[Any], int]:
    return lambda msg: inner(getattr(msg, name))


def _count_each(name: str, inner: Callable[[Any], int]) -> Callable[[Any], int]:
    return lambda msg: sum(map(inner, getattr(msg, name)))


_COUNTERS: dict[type, Callable[[Any], int]] = {}


def _none_counter_cached(cls: type) -> Callable[[Any], int]:
    counter = _COUNTERS.get(cls)
    if counter is None:
        counter = _COUNTERS[cls] = _none_counter(cls)
    return counter


def _nones(msg: Any) -> int:
    return _none_counter_cached(type(msg))(msg)


def _enc_hook(obj: Any) -> Any:
    # numpy scalars that slipped into a message built in code: as json.dumps would write them
    if hasattr(obj, "item") and callable(obj.item):
        value = obj.item()
        if isinstance(value, (int, float, bool)):
            return value
    raise TypeError(f"cannot encode {type(obj).__name__}")


_ENCODE = msgspec.json.Encoder(enc_hook=_enc_hook).encode


def encode(msg: Any) -> bytes:
    """Compact JSON bytes of a message; raises :class:`Refused` if it holds a non-finite float or
    anything else msgspec cannot write as the reference encoder would."""
    try:
        out = _ENCODE(msg)
    except (TypeError, ValueError, OverflowError, msgspec.EncodeError):
        raise Refused from None
    if b"null" in out and out.count(b"null") != _nones(msg):
        raise Refused  # a NaN or infinity written as null (or "null" inside a string: rare, exact anyway)
    return out

"""Declarative, validated dataclasses: one declaration gives decoding, encoding and JSON Schema.

Both the ICD messages and the YAML configuration are frozen dataclasses whose fields are made
with :func:`spec`. From that one declaration this module derives

* strict decoding from JSON-like data (``decode``), raising :class:`DecodeError` with the key
  path of the first offending value — wrong types, wrong lengths, non-finite numbers, unknown
  keys, unknown enum values, values out of range;
* lossless encoding back to JSON-like data (``encode``), optionally leaving out defaults;
* a JSON Schema (draft 2020-12) for MCAP/Foxglove channels (``json_schema``).

A class may take over its own handling by defining ``_typed_decode(data, path)`` (classmethod),
``_typed_encode(self, drop_defaults)`` and ``_typed_schema()`` (classmethod) — used for entries
whose parameter type depends on a name in the same mapping (e.g. a gating network's params).

Supported field types: ``bool``, ``int``, ``float``, ``str``, ``Literal[...]``, ``X | None``,
``tuple[float, ...]`` / ``tuple[int, ...]`` / ``tuple[str, ...]`` (vectors, with an optional
``shape`` in the spec), ``tuple[tuple[float, ...], ...]`` (matrices), ``tuple[D, ...]`` for a
nested dataclass D, ``dict[str, X]`` and nested dataclasses.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from functools import lru_cache
from typing import Any, Literal, get_args, get_origin

_MISSING = dataclasses.MISSING


class DecodeError(ValueError):
    """A value does not match its declaration. ``path`` is the dotted key path to it."""

    def __init__(self, path: str, expected: str, got: str):
        self.path = path
        self.expected = expected
        self.got = got
        super().__init__(f"{path or '<root>'}: expected {expected}, got {got}")


def spec(
    default: Any = _MISSING,
    *,
    doc: str,
    unit: str | None = None,
    ge: float | None = None,
    gt: float | None = None,
    le: float | None = None,
    lt: float | None = None,
    shape: tuple[int | None, ...] | None = None,
    max_items: int | None = None,
    max_length: int | None = None,
    default_factory: Any = _MISSING,
) -> Any:
    """A dataclass field with its documentation, unit and admissible range.

    ``shape`` constrains vectors/matrices: ``(3,)``, ``(6, 6)``; ``None`` in a dimension means
    "any length". ``max_items`` bounds every dimension of a list and the entries of a mapping,
    ``max_length`` the characters of a string (and of a mapping's keys): decoding checks them
    before it looks at a single element, so an oversized message costs no more than its length.
    Mutable defaults are not allowed; use tuples.
    """
    meta = {"doc": doc, "unit": unit, "ge": ge, "gt": gt, "le": le, "lt": lt, "shape": shape,
            "max_items": max_items, "max_length": max_length}
    if default_factory is not _MISSING:
        return dataclasses.field(default_factory=default_factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def did_you_mean(word: Any, choices: Any) -> str:
    """`` (did you mean 'x'?)`` for the choice closest to a mistyped ``word``, or nothing."""
    if not isinstance(word, str):
        return ""
    close = difflib.get_close_matches(word, [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _type_name(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"number {_short(value)}"
    if isinstance(value, str):
        return f"string {_short(value)}"
    if isinstance(value, (list, tuple)):
        return f"list of length {len(value)}"
    if isinstance(value, dict):
        return "mapping"
    return type(value).__name__


@lru_cache(maxsize=None)
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def fields_of(cls: type) -> list[tuple[dataclasses.Field, Any]]:
    """The dataclass fields of ``cls`` with their resolved type hints."""
    hints = _hints(cls)
    return [(f, hints[f.name]) for f in dataclasses.fields(cls)]


def _is_optional(tp: Any) -> tuple[bool, Any]:
    origin = get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in get_args(tp) if a is not type(None)]
        if len(args) == 1 and len(get_args(tp)) == 2:
            return True, args[0]
    return False, tp


def _check_range(value: float, meta: dict, path: str) -> None:
    ge, gt, le, lt = meta.get("ge"), meta.get("gt"), meta.get("le"), meta.get("lt")
    parts = []
    if ge is not None:
        parts.append(f">= {ge:g}")
    if gt is not None:
        parts.append(f"> {gt:g}")
    if le is not None:
        parts.append(f"<= {le:g}")
    if lt is not None:
        parts.append(f"< {lt:g}")
    ok = (
        (ge is None or value >= ge)
        and (gt is None or value > gt)
        and (le is None or value <= le)
        and (lt is None or value < lt)
    )
    if not ok:
        raise DecodeError(path, "a number " + " and ".join(parts), f"{value:g}")


def _check_items(value: list | tuple | dict, meta: dict, path: str) -> None:
    n = meta.get("max_items")
    if n is not None and len(value) > n:
        raise DecodeError(path, f"at most {n} {'entries' if isinstance(value, dict) else 'elements'}", f"{len(value)}")


def _check_length(value: str, meta: dict, path: str) -> None:
    n = meta.get("max_length")
    if n is not None and len(value) > n:
        raise DecodeError(path, f"a string of at most {n} characters", f"{len(value)} characters")


def _join(path: str, key: Any) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


def _decode_value(tp: Any, value: Any, path: str, meta: dict, dim: int = 0) -> Any:
    optional, inner = _is_optional(tp)
    if optional:
        if value is None:
            return None
        return _decode_value(inner, value, path, meta, dim)
    if tp is Any:
        return value
    if hasattr(tp, "_typed_decode"):
        return tp._typed_decode(value, path)
    origin = get_origin(tp)
    if tp is bool:
        if not isinstance(value, bool):
            raise DecodeError(path, "a boolean (true/false)", _type_name(value))
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer() and math.isfinite(value):
                value = int(value)
            else:
                raise DecodeError(path, "an integer", _type_name(value))
        _check_range(value, meta, path)
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DecodeError(path, "a number", _type_name(value))
        value = float(value)
        if not math.isfinite(value):
            raise DecodeError(path, "a finite number", _short(value))
        _check_range(value, meta, path)
        return value
    if tp is str:
        if not isinstance(value, str):
            raise DecodeError(path, "a string", _type_name(value))
        _check_length(value, meta, path)
        return value
    if origin is Literal:
        choices = get_args(tp)
        if value not in choices or isinstance(value, bool) != isinstance(choices[0], bool):
            raise DecodeError(path, "one of " + ", ".join(map(str, choices)),
                              _type_name(value) + did_you_mean(value, choices))
        return value
    if origin is tuple:
        args = get_args(tp)
        if not isinstance(value, (list, tuple)):
            raise DecodeError(path, "a list", _type_name(value))
        _check_items(value, meta, path)
        shape = meta.get("shape")
        if shape is not None and dim < len(shape) and shape[dim] is not None:
            if len(value) != shape[dim]:
                raise DecodeError(path, f"a list of length {shape[dim]}", f"length {len(value)}")
        if len(args) == 2 and args[1] is Ellipsis:
            elem_meta = meta if dataclasses.is_dataclass(args[0]) is False else {}
            return tuple(
                _decode_value(args[0], v, _join(path, i), elem_meta, dim + 1)
                for i, v in enumerate(value)
            )
        if len(value) != len(args):
            raise DecodeError(path, f"a list of length {len(args)}", f"length {len(value)}")
        return tuple(_decode_value(a, v, _join(path, i), {}, dim + 1) for i, (a, v) in enumerate(zip(args, value)))
    if origin is dict:
        ktype, vtype = get_args(tp)
        if not isinstance(value, dict):
            raise DecodeError(path, "a mapping", _type_name(value))
        _check_items(value, meta, path)
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise DecodeError(path, "string keys", _type_name(k))
            _check_length(k, meta, path)
            out[k] = _decode_value(vtype, v, _join(path, k), meta, dim)
        return out
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return decode(tp, value, path)
    raise TypeError(f"unsupported field type {tp!r} at {path}")


def decode(cls: type, data: Any, path: str = "") -> Any:
    """Build a ``cls`` instance from JSON-like ``data``, validating every field strictly."""
    if not isinstance(data, dict):
        raise DecodeError(path, f"a mapping ({cls.__name__})", _type_name(data))
    known = {f.name for f in dataclasses.fields(cls)}
    for key in data:
        if key not in known:
            raise DecodeError(
                _join(path, key), "one of the keys " + ", ".join(sorted(known)),
                f"unknown key {key!r}" + did_you_mean(key, known),
            )
    kwargs = {}
    for f, tp in fields_of(cls):
        fpath = _join(path, f.name)
        if f.name in data:
            kwargs[f.name] = _decode_value(tp, data[f.name], fpath, dict(f.metadata))
        elif f.default is _MISSING and f.default_factory is _MISSING:
            raise DecodeError(fpath, f"a value ({f.metadata.get('doc', 'required')})", "nothing (missing key)")
    try:
        obj = cls(**kwargs)
    except DecodeError:
        raise
    except (ValueError, TypeError) as exc:  # cross-field checks in __post_init__
        raise DecodeError(path, "consistent values", str(exc)) from None
    return obj


def _encode_value(value: Any, drop_defaults: bool) -> Any:
    if hasattr(value, "_typed_encode"):
        return value._typed_encode(drop_defaults)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return encode(value, drop_defaults=drop_defaults)
    if isinstance(value, tuple):
        return [_encode_value(v, drop_defaults) for v in value]
    if isinstance(value, dict):
        return {k: _encode_value(v, drop_defaults) for k, v in value.items()}
    return value


def encode(obj: Any, drop_defaults: bool = False) -> dict:
    """JSON-like data for a dataclass instance (the inverse of :func:`decode`)."""
    out = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if drop_defaults:
            if f.default is not _MISSING and value == f.default:
                continue
            if f.default_factory is not _MISSING and value == f.default_factory():
                continue
        out[f.name] = _encode_value(value, drop_defaults)
    return out


def _schema_of(tp: Any, meta: dict, dim: int = 0) -> dict:
    optional, inner = _is_optional(tp)
    if optional:
        return {"anyOf": [_schema_of(inner, meta, dim), {"type": "null"}]}
    origin = get_origin(tp)
    if tp is Any:
        return {}
    if hasattr(tp, "_typed_schema"):
        return tp._typed_schema()
    if tp is bool:
        return {"type": "boolean"}
    if tp in (int, float):
        out: dict = {"type": "integer" if tp is int else "number"}
        for key, js in (("ge", "minimum"), ("gt", "exclusiveMinimum"), ("le", "maximum"), ("lt", "exclusiveMaximum")):
            if meta.get(key) is not None:
                out[js] = meta[key]
        return out
    if tp is str:
        out = {"type": "string"}
        if meta.get("max_length") is not None:
            out["maxLength"] = meta["max_length"]
        return out
    if origin is Literal:
        return {"enum": list(get_args(tp))}
    if origin is tuple:
        args = get_args(tp)
        out = {"type": "array"}
        if len(args) == 2 and args[1] is Ellipsis:
            out["items"] = _schema_of(args[0], meta if not dataclasses.is_dataclass(args[0]) else {}, dim + 1)
            shape = meta.get("shape")
            if shape is not None and dim < len(shape) and shape[dim] is not None:
                out["minItems"] = out["maxItems"] = shape[dim]
            elif meta.get("max_items") is not None:
                out["maxItems"] = meta["max_items"]
        else:
            out["prefixItems"] = [_schema_of(a, {}, dim + 1) for a in args]
            out["minItems"] = out["maxItems"] = len(args)
            out["items"] = False
        return out
    if origin is dict:
        out = {"type": "object", "additionalProperties": _schema_of(get_args(tp)[1], meta, dim)}
        if meta.get("max_items") is not None:
            out["maxProperties"] = meta["max_items"]
        if meta.get("max_length") is not None:
            out["propertyNames"] = {"maxLength": meta["max_length"]}
        return out
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return json_schema(tp, top=False)
    raise TypeError(f"unsupported field type {tp!r}")


def json_schema(cls: type, top: bool = True) -> dict:
    """A JSON Schema (draft 2020-12) generated from the declaration of ``cls``."""
    props = {}
    required = []
    for f, tp in fields_of(cls):
        meta = dict(f.metadata)
        sch = _schema_of(tp, meta)
        desc = meta.get("doc", "")
        if meta.get("unit"):
            desc = f"{desc} [{meta['unit']}]"
        if desc:
            sch["description"] = desc
        if f.default is not _MISSING:
            sch["default"] = _encode_value(f.default, False)
        else:
            if f.default_factory is _MISSING:
                required.append(f.name)
        props[f.name] = sch
    out: dict = {"type": "object", "title": cls.__name__, "properties": props, "additionalProperties": False}
    if cls.__doc__:
        out["description"] = cls.__doc__.strip().splitlines()[0]
    if required:
        out["required"] = required
    if top:
        out = {"$schema": "https://json-schema.org/draft/2020-12/schema", **out}
    return out

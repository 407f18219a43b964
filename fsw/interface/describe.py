"""Plain-language descriptions of declared fields: type, unit, admissible range, default.

The ``spec(doc, unit, range)`` of every field already says what a key means; this module words
it for people, once, for both the generated configuration reference (``docs/scenarios.md``) and
the comments of ``navbank scenarios --show``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal, get_args, get_origin

import yaml

from fsw.interface.typed import _encode_value, _is_optional, fields_of

_MISSING = dataclasses.MISSING


@dataclass(frozen=True)
class FieldDoc:
    """One key of a declaration, described: ``path`` is dotted (``sim.faults[].type``)."""

    path: str
    type: str
    unit: str
    range: str
    default: str
    doc: str


def _number(value: float) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def range_text(meta: dict) -> str:
    """``≥ 0``, ``> 0 and ≤ 2``: the admissible range of a number, empty when unbounded."""
    parts = []
    for key, sign in (("ge", "≥"), ("gt", ">"), ("le", "≤"), ("lt", "<")):
        if meta.get(key) is not None:
            parts.append(f"{sign} {_number(meta[key])}")
    return " and ".join(parts)


def _plural(name: str) -> str:
    return {"matrix": "matrices", "boolean": "booleans", "integer": "integers", "number": "numbers",
            "string": "strings"}.get(name, name + "s")


def type_text(tp: Any, meta: dict | None = None, dim: int = 0) -> str:
    """The type of a field in words (``number``, ``list of 3 numbers``, ``one of a, b``)."""
    meta = meta or {}
    optional, inner = _is_optional(tp)
    if optional:
        return type_text(inner, meta, dim) + " or null"
    if tp is bool:
        return "boolean"
    if tp is int:
        return "integer"
    if tp is float:
        return "number"
    if tp is str:
        return "string"
    if tp is Any:
        return "any"
    origin = get_origin(tp)
    if origin is Literal:
        return "one of " + ", ".join(str(a) for a in get_args(tp))
    if origin is tuple:
        args = get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            item = args[0]
            if dataclasses.is_dataclass(item) or hasattr(item, "_typed_decode"):
                return f"list of {item.__name__}"
            shape = meta.get("shape")
            n = shape[dim] if shape is not None and dim < len(shape) else None
            inner_text = type_text(item, meta, dim + 1)
            if get_origin(item) is tuple:
                return "matrix (list of rows)" if n is None else f"matrix of {n} rows"
            return f"list of {n} {_plural(inner_text)}" if n else f"list of {_plural(inner_text)}"
        return "list (" + ", ".join(type_text(a) for a in args) + ")"
    if origin is dict:
        return f"mapping of name to {type_text(get_args(tp)[1], meta, dim)}"
    if isinstance(tp, type):
        return "section" if dataclasses.is_dataclass(tp) else tp.__name__
    return str(tp)


def flow(value: Any) -> str:
    """A JSON-like value as YAML in flow style on one line (``[0.6, 0.0, 0.8]``, ``null``,
    ``'2018-11-26T19:47:00'``): PyYAML decides the quoting, so the text reads back as the value."""
    text = yaml.safe_dump(value, default_flow_style=True, width=math.inf, allow_unicode=True, sort_keys=False)
    return text.removesuffix("\n").removesuffix("\n...").strip()


def _round(value: Any) -> Any:
    """Floats to 10 significant digits, for reading (2.2118399999999997e-25 → 2.21184e-25)."""
    if isinstance(value, float):
        return float(f"{value:.10g}")
    if isinstance(value, list):
        return [_round(v) for v in value]
    if isinstance(value, dict):
        return {k: _round(v) for k, v in value.items()}
    return value


def default_text(f: dataclasses.Field) -> str:
    """The default of a field as YAML, ``(required)`` when there is none, ``(section)`` when it
    is a nested declaration whose own keys have their defaults."""
    if f.default is not _MISSING:
        value = f.default
    elif f.default_factory is not _MISSING:
        value = f.default_factory()
    else:
        return "(required)"
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return "(section)"
    text = flow(_round(_encode_value(value, False)))
    return text if len(text) <= 40 else "(see the built-in scenarios)"


def comment(f: dataclasses.Field) -> str:
    """The comment of a field in YAML: its doc, its unit in brackets, its range."""
    meta = f.metadata
    text = meta.get("doc", "")
    unit = meta.get("unit")
    if unit and unit != "1":
        text += f" [{unit}]"
    rng = range_text(dict(meta))
    if rng:
        text += f" ({rng})"
    return text


def _nested(tp: Any) -> type | None:
    """The declaration a field nests (directly, optional, or as list items), if any."""
    _, inner = _is_optional(tp)
    if get_origin(inner) is tuple:
        args = get_args(inner)
        if len(args) == 2 and args[1] is Ellipsis:
            inner = args[0]
    # a class that decodes itself from undeclared fields (a gating entry) is described by its owner
    if isinstance(inner, type) and dataclasses.is_dataclass(inner) and all(
            "doc" in f.metadata for f in dataclasses.fields(inner)):
        return inner
    return None


def _is_list(tp: Any) -> bool:
    _, inner = _is_optional(tp)
    return get_origin(inner) is tuple


def describe(cls: type, prefix: str = "") -> list[FieldDoc]:
    """Every key of declaration ``cls``, nested declarations flattened into dotted paths."""
    rows = []
    for f, tp in fields_of(cls):
        path = f"{prefix}.{f.name}" if prefix else f.name
        meta = dict(f.metadata)
        unit = meta.get("unit") or ""
        rows.append(FieldDoc(path=path, type=type_text(tp, meta), unit=unit, range=range_text(meta),
                             default=default_text(f), doc=meta.get("doc", "")))
        nested = _nested(tp)
        if nested is not None:
            rows.extend(describe(nested, path + ("[]" if _is_list(tp) else "")))
    return rows

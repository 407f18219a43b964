"""A configuration as YAML with a comment on every key: its doc, unit and range.

What ``navbank scenarios --show`` prints: block style, one key a line, each followed by what its
declaration says of it, so the file explains itself when a user edits it. A key whose value is
null and whose default is null is left out (writing it changes nothing); the text reads back
into exactly the same configuration.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from fsw.interface.describe import comment, flow
from fsw.interface.typed import _encode_value

_MISSING = dataclasses.MISSING


def _line(indent: str, key: str, value: str, note: str) -> str:
    text = f"{indent}{key}:" + (f" {value}" if value else "")
    return f"{text}  # {note}" if note else text


def _is_plain_dataclass(value: Any) -> bool:
    return dataclasses.is_dataclass(value) and not isinstance(value, type) and not hasattr(value, "_typed_encode")


def _entries(obj: Any) -> list[tuple[str, Any, str, bool]]:
    """(key, value, comment, omittable) of each key of ``obj``, in declaration order.

    A class that decodes itself from one mapping may say what its keys are with
    ``_typed_annotated()`` -> (leading (key, value, comment) triples, a declaration instance
    whose keys follow in the same mapping)."""
    if hasattr(obj, "_typed_annotated"):
        head, body = obj._typed_annotated()
        return [(k, v, c, False) for k, v, c in head] + _entries(body)
    out = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        omittable = value is None and f.default is None
        out.append((f.name, value, comment(f), omittable))
    return out


def _mapping(obj: Any, indent: str) -> list[str]:
    lines: list[str] = []
    for key, value, note, omittable in _entries(obj):
        if omittable:
            continue
        lines.extend(_value_lines(key, value, note, indent))
    return lines


def _is_section(value: Any) -> bool:
    return _is_plain_dataclass(value) or hasattr(value, "_typed_annotated")


def _value_lines(key: str, value: Any, note: str, indent: str) -> list[str]:
    if _is_section(value):
        return [_line(indent, key, "", note), *_mapping(value, indent + "  ")]
    if isinstance(value, tuple) and value and all(_is_section(v) for v in value):
        lines = [_line(indent, key, "", note)]
        for item in value:
            body = _mapping(item, indent + "    ")
            if body:  # the first key goes on the dash's line
                body[0] = indent + "  - " + body[0][len(indent) + 4:]
            else:
                body = [indent + "  - {}"]
            lines.extend(body)
        return lines
    return [_line(indent, key, flow(_encode_value(value, False)), note)]


def annotated_yaml(obj: Any, header: str = "") -> str:
    """YAML text of configuration ``obj`` (a declaration instance) with a comment on every key;
    ``header`` (possibly several lines) is written first as comment lines."""
    lines = [f"# {h}".rstrip() for h in header.splitlines()] if header else []
    lines.extend(_mapping(obj, ""))
    return "\n".join(lines) + "\n"

"""YAML configuration files loaded into validated dataclasses, with errors that point at a line.

A bad file gives exactly one line, ``FILE:LINE: key.path: expected …, got …`` (a
:class:`ConfigError`), for YAML syntax errors, duplicate keys, unknown keys, wrong types,
out-of-range values and missing required keys alike. Callers turn it into exit code 2.

PyYAML is a core dependency of the package; this module is the only place in ``fsw.interface``
that uses it, because both the FSW and the simulator receive their configuration through it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, TypeVar

import yaml

from fsw.interface.typed import DecodeError, decode, encode

T = TypeVar("T")


class ConfigError(ValueError):
    """One-line configuration error: ``FILE:LINE: key.path: expected …, got …``."""

    def __init__(self, file: str, line: int | None, path: str, expected: str, got: str):
        self.file, self.line, self.path, self.expected, self.got = file, line, path, expected, got
        where = f"{file}:{line}" if line else file
        super().__init__(f"{where}: {path or '<top level>'}: expected {expected}, got {got}")


class _LineLoader(yaml.SafeLoader):
    """Safe loader that keeps nodes (for line numbers)."""


def _construct(node: yaml.Node, path: str, lines: dict[str, int], file: str) -> Any:
    lines.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        out: dict[str, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                raise ConfigError(file, key_node.start_mark.line + 1, path, "a plain key", "a complex key")
            key = _LineLoader.construct_scalar(_LOADER, key_node)
            sub = f"{path}.{key}" if path else str(key)
            if key in out:
                raise ConfigError(file, key_node.start_mark.line + 1, sub, "each key once", "a duplicate key")
            lines[sub] = key_node.start_mark.line + 1
            out[key] = _construct(value_node, sub, lines, file)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_construct(v, f"{path}[{i}]", lines, file) for i, v in enumerate(node.value)]
    return _LOADER.construct_object(node, deep=True)


_LOADER = _LineLoader("")


def parse_yaml(text: str, file: str = "<string>") -> tuple[Any, dict[str, int]]:
    """Parse YAML text into plain data plus a map from key path to 1-based line number."""
    try:
        node = yaml.compose(text, Loader=_LineLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        raise ConfigError(file, line, "", "valid YAML", (exc.problem or "a syntax error").strip()) from None
    except yaml.YAMLError as exc:
        raise ConfigError(file, None, "", "valid YAML", str(exc).splitlines()[0]) from None
    if node is None:
        return {}, {}
    lines: dict[str, int] = {}
    try:
        data = _construct(node, "", lines, file)
    except yaml.constructor.ConstructorError as exc:
        mark = exc.problem_mark
        raise ConfigError(file, mark.line + 1 if mark else None, "", "valid YAML values", str(exc.problem)) from None
    return data, lines


def _line_for(path: str, lines: dict[str, int]) -> int | None:
    """Line of ``path``, or of its nearest ancestor that exists in the file."""
    while True:
        if path in lines:
            return lines[path]
        if not path:
            return None
        cut = max(path.rfind("."), path.rfind("["))
        path = path[:cut] if cut > 0 else ""


def load_data(cls: type[T], data: Any, lines: dict[str, int], file: str) -> T:
    """Validate already-parsed data (with its line map) as ``cls``."""
    try:
        return decode(cls, data)
    except DecodeError as exc:
        raise ConfigError(file, _line_for(exc.path, lines), exc.path, exc.expected, exc.got) from None


def load_text(cls: type[T], text: str, file: str = "<string>") -> T:
    data, lines = parse_yaml(text, file)
    return load_data(cls, data, lines, file)


def read_config_text(path: str | Path) -> str:
    """The text of a configuration file; a missing or unreadable file is a one-line ConfigError."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(str(path), None, "", "an existing file", "no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(str(path), None, "", "a readable UTF-8 text file", exc.__class__.__name__) from None


def load_file(cls: type[T], path: str | Path) -> T:
    """Load and validate a YAML file as ``cls``; every failure is a one-line ConfigError."""
    return load_text(cls, read_config_text(path), str(path))


def dump_yaml(obj: Any, drop_defaults: bool = True) -> str:
    """YAML text of a config object; with ``drop_defaults`` only what differs from the defaults."""
    if not dataclasses.is_dataclass(obj):
        raise TypeError("dump_yaml expects a dataclass instance")
    return yaml.safe_dump(encode(obj, drop_defaults=drop_defaults), sort_keys=False, default_flow_style=None, width=100,
                          allow_unicode=True)

"""YAML configuration files loaded into validated dataclasses, with errors that point at a line.

A bad file gives exactly one line, ``FILE:LINE: key.path: expected …, got …`` (a
:class:`ConfigError`), for YAML syntax errors, duplicate keys, unknown keys, wrong types,
out-of-range values and missing required keys alike. Callers turn it into exit code 2.

PyYAML is a core dependency of the package; this module is the only place in ``fsw.interface``
that uses it, because both the FSW and the simulator receive their configuration through it.

Every file read here is treated as hostile input (scenario and campaign files, detector
calibrations, the configuration attached to a recorded MCAP), so what a file can cost is bounded
before it is paid: its size (:data:`MAX_BYTES`, checked before parsing), the nesting of its
mappings and lists (:data:`MAX_DEPTH`, checked while composing, before Python's recursion limit
is reached), the number of aliases (:data:`MAX_ALIASES`) and the number of nodes once aliases are
expanded (:data:`MAX_NODES`). The expanded size is added up node by node as the file is composed
(an alias costs the size of what it names), so a "billion laughs" file is refused after reading
its few hundred bytes, not after building its billion values. A breach is a one-line
:class:`ConfigError` like any other bad file.
"""

from __future__ import annotations

import dataclasses
import os
import stat
from pathlib import Path
from typing import Any, TypeVar

import yaml

from fsw.interface.typed import DecodeError, decode, encode

T = TypeVar("T")

#: Largest configuration file, in bytes (4 MiB). The largest built-in file is about 10 kB; a
#: recorded run's complete configuration is of the same order.
MAX_BYTES = 4 * 1024 * 1024
#: Deepest nesting of mappings and lists, aliases expanded. Scenario files nest about 6 deep.
MAX_DEPTH = 64
#: Most alias uses (``*name``) in one file. The built-in Pathfinder scenario, the one that shares
#: blocks between filters, uses 44.
MAX_ALIASES = 1000
#: Most nodes (keys, values, list items) of one file with every alias expanded. The built-in
#: files have at most a few thousand; composing 100 000 nodes takes PyYAML about two seconds and
#: 100 MB, a million twenty seconds and a gigabyte.
MAX_NODES = 100_000


class ConfigError(ValueError):
    """One-line configuration error: ``FILE:LINE: key.path: expected …, got …``."""

    def __init__(self, file: str, line: int | None, path: str, expected: str, got: str):
        self.file, self.line, self.path, self.expected, self.got = file, line, path, expected, got
        where = f"{file}:{line}" if line else file
        super().__init__(f"{where}: {path or '<top level>'}: expected {expected}, got {got}")


class _Breach(Exception):
    """A limit was exceeded while composing; :func:`parse_yaml` turns it into a ConfigError."""

    def __init__(self, mark: yaml.Mark | None, path: str, expected: str, got: str):
        super().__init__(expected)
        self.line = mark.line + 1 if mark is not None else None
        # a path 64 levels deep is long; its start says where in the file the breach is
        self.path = path if len(path) <= 80 else path[:80] + "…"
        self.expected, self.got = expected, got


class _LineLoader(yaml.SafeLoader):
    """Safe loader that keeps nodes (for line numbers) and enforces the size limits.

    ``compose_node`` is PyYAML's one recursive step of composition; overriding it sees every node
    as it is made: the open collections on the way down (depth, before recursing further), and
    on the way up the node's expanded size and depth from its children's, which are known by
    then. An alias can only name a node whose composition has finished — an alias to a node
    still being composed (``&a [*a]``) would make a cycle that no construction can end.
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._open = 0  # collections being composed (nesting on the way down)
        self._aliases = 0
        self._path: list[str] = []
        self._cost: dict[int, tuple[int, int]] = {}  # id(node) -> (expanded nodes, expanded depth)
        # nodes of the document so far, aliases expanded: checked at every node, so a long flat
        # list stops at the limit instead of being composed to its end first
        self._total = 0

    def _where(self) -> str:
        return "".join(self._path).lstrip(".")

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        if isinstance(parent, yaml.MappingNode) and isinstance(index, yaml.ScalarNode):
            step = f".{index.value}"
        elif isinstance(parent, yaml.SequenceNode) and isinstance(index, int):
            step = f"[{index}]"
        else:
            step = ""  # the document itself, or a mapping key
        self._path.append(step)
        try:
            return self._compose_counted(parent, index)
        finally:
            self._path.pop()

    def _count(self, event: yaml.Event, nodes: int) -> None:
        self._total += nodes
        if self._total > MAX_NODES:
            raise _Breach(event.start_mark, self._where(), f"at most {MAX_NODES} nodes with aliases expanded",
                          f"{self._total} by here")

    def _compose_counted(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise _Breach(event.start_mark, self._where(), f"at most {MAX_ALIASES} aliases (*name)", "more")
            node = super().compose_node(parent, index)
            if id(node) not in self._cost:
                raise _Breach(event.start_mark, self._where(), "an alias to a finished node",
                              f"a recursive alias *{event.anchor}")
            self._count(event, self._cost[id(node)][0])
            return node
        self._count(event, 1)
        collection = isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent))
        if collection:
            self._open += 1
            if self._open > MAX_DEPTH:
                raise _Breach(event.start_mark, self._where(), f"nesting at most {MAX_DEPTH} deep", "deeper")
        try:
            node = super().compose_node(parent, index)
        finally:
            if collection:
                self._open -= 1
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = list(node.value)
        else:
            children = []
        # the running total has bounded the size already (a node's size is part of it)
        size = 1 + sum(self._cost[id(c)][0] for c in children)
        depth = int(collection) + max((self._cost[id(c)][1] for c in children), default=0)
        if depth > MAX_DEPTH:
            raise _Breach(event.start_mark, self._where(), f"nesting at most {MAX_DEPTH} deep with aliases expanded",
                          f"{depth}")
        self._cost[id(node)] = (size, depth)
        return node


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
    """Parse YAML text into plain data plus a map from key path to 1-based line number.

    Text beyond the limits of this module (size, nesting, aliases, expanded nodes) is a
    :class:`ConfigError` raised before the data is built."""
    # characters never outnumber UTF-8 bytes: encode only text that could be too large
    if len(text) > MAX_BYTES // 4 and len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise ConfigError(file, None, "", f"at most {MAX_BYTES} bytes (4 MiB) of YAML",
                          f"{len(text.encode('utf-8', 'surrogatepass'))} bytes")
    try:
        node = yaml.compose(text, Loader=_LineLoader)
    except _Breach as exc:
        raise ConfigError(file, exc.line, exc.path, exc.expected, exc.got) from None
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
    """The text of a configuration file; a missing, unreadable or too large file is a one-line
    ConfigError. The size is checked before reading: a regular file by its length, anything else
    (a FIFO, a device) by reading at most one byte more than the limit."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            if stat.S_ISREG(st.st_mode) and st.st_size > MAX_BYTES:
                raise ConfigError(str(path), None, "", f"a file of at most {MAX_BYTES} bytes (4 MiB)",
                                  f"{st.st_size} bytes")
            data = f.read(MAX_BYTES + 1)
        if len(data) > MAX_BYTES:
            raise ConfigError(str(path), None, "", f"a file of at most {MAX_BYTES} bytes (4 MiB)", "more")
        return data.decode("utf-8")
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

"""The FSW configuration of a recorded run, optionally changed, for a re-run.

``navbank run`` attaches the complete scenario YAML (``fsw.initial_state`` filled in) to the MCAP.
Only its ``fsw:`` mapping is used: it is taken out of the parsed file and validated as
:class:`~fsw.config.FswConfig` with the file's line map, so a bad value is one
``FILE:LINE: fsw.path: expected …, got …`` line (:class:`~fsw.interface.yamlconfig.ConfigError`).

Changes for a what-if re-run:

* ``--set fsw.gating[0].sigma_w=0.1`` — one value, by key path (``name`` or ``name[i]`` steps);
  the value is read as YAML (``0.1``, ``true``, ``[1, 2]``, ``null``, ``cpu``);
* ``--config FILE`` — a scenario file (its ``fsw:`` section) or a bare ``fsw`` mapping that
  replaces the recorded one; without an ``initial_state`` it keeps the recorded a-priori state,
  since a different starting point would make every estimate differ for a trivial reason.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fsw.config import FswConfig
from fsw.interface.yamlconfig import ConfigError, load_data, parse_yaml, read_config_text

_STEP = re.compile(r"([^.\[\]]+)|\[(\d+)\]")
SCENARIO_KEYS = ("name", "description", "seed", "sim", "fsw")


def fsw_section(data: Any, lines: dict[str, int], file: str) -> tuple[dict, dict[str, int]]:
    """The ``fsw`` mapping of a parsed scenario and its line map re-rooted at it."""
    if not isinstance(data, dict):
        raise ConfigError(file, lines.get(""), "", "a scenario mapping with an fsw: section", type(data).__name__)
    fsw = data.get("fsw", {})
    if fsw is None:
        fsw = {}
    if not isinstance(fsw, dict):
        raise ConfigError(file, lines.get("fsw"), "fsw", "a mapping", type(fsw).__name__)
    sub = {k[len("fsw."):]: v for k, v in lines.items() if k.startswith("fsw.")}
    if "fsw" in lines:
        sub[""] = lines["fsw"]
    return fsw, sub


def parse_override(text: str) -> tuple[list[str | int], Any]:
    """``fsw.a.b[2].c=VALUE`` → (steps below ``fsw``, YAML value); ValueError if malformed."""
    if "=" not in text:
        raise ValueError(f"--set {text!r}: expected fsw.PATH=VALUE")
    path, value_text = text.split("=", 1)
    path = path.strip()
    steps: list[str | int] = []
    for part in path.split("."):
        if not part:
            raise ValueError(f"--set {text!r}: empty key in {path!r}")
        matched = 0
        for m in _STEP.finditer(part):
            if m.start() != matched:
                break
            steps.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
            matched = m.end()
        if matched != len(part):
            raise ValueError(f"--set {text!r}: cannot read key {part!r}")
    if not steps or steps[0] != "fsw" or len(steps) < 2:
        raise ValueError(f"--set {text!r}: the path must start with fsw. (only the FSW is re-run)")
    # the value goes through the same bounded parser as every configuration file
    try:
        value = parse_yaml(value_text, f"--set {text!r}")[0] if value_text.strip() else ""
    except ConfigError as exc:
        raise ValueError(f"--set {text!r}: the value is not valid YAML ({exc.expected}, got {exc.got})") from None
    return steps[1:], value


def apply_override(data: dict, steps: list[str | int], value: Any, label: str) -> None:
    """Set ``value`` at ``steps`` inside ``data`` (mappings may gain keys; lists only by index)."""
    node: Any = data
    where = "fsw"
    for i, step in enumerate(steps):
        last = i == len(steps) - 1
        if isinstance(step, int):
            if not isinstance(node, list) or not -len(node) <= step < len(node):
                size = f"a list of {len(node)}" if isinstance(node, list) else type(node).__name__
                raise ValueError(f"--set {label}: {where}[{step}] does not exist ({where} is {size})")
            where = f"{where}[{step}]"
        else:
            if not isinstance(node, dict):
                raise ValueError(f"--set {label}: {where} is not a mapping, cannot set {step!r} in it")
            where = f"{where}.{step}"
            if not last and step not in node:
                node[step] = {}
        if last:
            node[step] = value
        else:
            node = node[step]


def load_fsw_config(
    text: str,
    file: str,
    *,
    overrides: Sequence[str] = (),
    replacement: str | Path | None = None,
) -> FswConfig:
    """The recorded FSW config (``text``: the attached scenario YAML), changed as asked.

    Raises :class:`ConfigError` (one line) for an invalid file or result, ValueError for a
    malformed ``--set``.
    """
    data, lines = parse_yaml(text, file)
    fsw, fsw_lines = fsw_section(data, lines, file)
    label = file
    if replacement is not None:
        rpath = Path(replacement)
        rtext = read_config_text(rpath)
        rdata, rlines = parse_yaml(rtext, str(rpath))
        if isinstance(rdata, dict) and any(k in rdata for k in SCENARIO_KEYS):
            new, new_lines = fsw_section(rdata, rlines, str(rpath))
        else:
            new, new_lines = rdata, rlines
        if not isinstance(new, dict):
            raise ConfigError(str(rpath), rlines.get(""), "", "an fsw mapping or a scenario with fsw:", type(new).__name__)
        if "initial_state" not in new or new.get("initial_state") is None:
            new = {**new, "initial_state": fsw.get("initial_state")}
        fsw, fsw_lines, label = new, new_lines, str(rpath)
    changed: list[str] = []
    for item in overrides:
        steps, value = parse_override(item)
        apply_override(fsw, steps, value, item)
        changed.append(_dotted(steps))
        # an error in an overridden value points at the option, not at a line of the file
        for k in [k for k in fsw_lines if _under(k, changed[-1])]:
            del fsw_lines[k]
    try:
        return load_data(FswConfig, fsw, fsw_lines, label)
    except ConfigError as exc:
        path = f"fsw.{exc.path}" if exc.path else "fsw"
        hits = [o for o, c in zip(overrides, changed) if _under(exc.path, c) or (exc.path and _under(c, exc.path))]
        if hits:
            raise ConfigError(f"--set {hits[0]}", None, path, exc.expected, exc.got) from None
        raise ConfigError(label, exc.line, path, exc.expected, exc.got) from None


def _under(path: str, prefix: str) -> bool:
    return path == prefix or path.startswith(prefix + ".") or path.startswith(prefix + "[")


def _dotted(steps: list[str | int]) -> str:
    out = ""
    for s in steps:
        out += f"[{s}]" if isinstance(s, int) else (f".{s}" if out else str(s))
    return out

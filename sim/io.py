"""A run as a ``.jsonl`` file: one ICD message per line, with its topic and type.

Line format: ``{"topic": "/sim/measurements", "type": "Measurement", "msg": {...}}`` — the MCAP
topic of the message (``fsw.interface.topics.mcap_topic``), its ICD type name and its fields as
``fsw.interface.codec`` encodes them. Floats are written with Python's shortest round-trip
repr, so equal runs give byte-identical files and reading back restores every value exactly.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Iterable, Iterator

from fsw.interface import codec, topics


class JsonlError(ValueError):
    """A line of a run file is not a valid ``{"topic", "type", "msg"}`` ICD record."""

    def __init__(self, path: str, line: int, problem: str):
        self.path, self.line = path, line
        super().__init__(f"{path}:{line}: {problem}")


def encode_line(topic: str, msg) -> str:
    """One jsonl line (without newline) for a message on a topic."""
    return json.dumps(
        {"topic": topics.mcap_topic(topic), "type": type(msg).__name__, "msg": codec.to_dict(msg)},
        separators=(",", ":"),
        allow_nan=False,
    )


def write_jsonl(messages: Iterable[tuple[str, object]], path: str | Path) -> int:
    """Write (topic, message) pairs — e.g. ``SimRun.iter_messages()`` — to ``path``; returns the count."""
    n = 0
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        for topic, msg in messages:
            fh.write(encode_line(topic, msg))
            fh.write("\n")
            n += 1
    return n


def write_run(run, path: str | Path) -> int:
    """Write every message of a :class:`sim.stream.SimRun` in time order."""
    return write_jsonl(run.iter_messages(), path)


def iter_jsonl(path: str | Path) -> Iterator[tuple[str, object]]:
    """Read back (topic, message) pairs, topics as written (``/sim/...``); strict ICD decoding."""
    name = str(path)
    with open(path, encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, start=1):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
            except ValueError as exc:
                raise JsonlError(name, lineno, f"not JSON ({exc})") from None
            if not isinstance(rec, dict) or set(rec) != {"topic", "type", "msg"}:
                raise JsonlError(name, lineno, 'expected an object with keys "topic", "type", "msg"')
            topic, type_name = rec["topic"], rec["type"]
            if not isinstance(topic, str) or not isinstance(type_name, str):
                raise JsonlError(name, lineno, "topic and type must be strings")
            try:
                cls = codec.type_by_name(type_name)
                expected = topics.type_of_topic(topic)
            except (codec.ICDError, KeyError) as exc:
                raise JsonlError(name, lineno, f"unknown type or topic ({exc})") from None
            if expected is not cls:
                raise JsonlError(name, lineno, f"topic {topic} carries {expected.__name__}, not {type_name}")
            try:
                msg: object = codec.from_dict(cls, rec["msg"])
            except codec.ICDError as exc:
                raise JsonlError(name, lineno, str(exc)) from None
            yield topic, msg


def read_jsonl(path: str | Path) -> list[tuple[str, object]]:
    """All (topic, message) pairs of a run file."""
    return list(iter_jsonl(path))

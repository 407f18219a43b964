"""The campaign directory: ``runs.jsonl`` (one row per finished run), ``plan.json``, weights.

Rows are appended one line at a time with a single ``write`` on an ``O_APPEND`` descriptor
followed by ``fsync``, so after a crash the file holds whole rows plus at most one torn last line
(no trailing newline). Reading skips a torn last line; :meth:`RunStore.open` cuts it off before
appending, so a resumed campaign never glues a new row onto half an old one. A later row for the
same id (``--rerun-failed``) supersedes the earlier one.

Weight histories (``navbank calibrate``, campaigns' ``keep_weights``) go to ``weights/<network>/<id>.npz``, written to a temporary name
and renamed *before* the row is appended: a row never points at a missing or partial file. Run
recordings (campaigns' ``keep_mcap``) go to ``mcap/<id>.mcap`` the same way.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fsw.interface.typed import DecodeError
from ground.report.row_types import ResultRow
from ground.report.run_weights import RunWeights

RUNS = "runs.jsonl"
PLAN = "plan.json"
WEIGHTS = "weights"
MCAP = "mcap"
SUMMARY = "summary.json"
REPORT = "report.md"


def _clean(value: Any) -> Any:
    """JSON-safe copy: numpy scalars to Python, non-finite floats to null (strict JSON)."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def encode_row(row: ResultRow) -> bytes:
    return (json.dumps(_clean(row.to_json()), separators=(",", ":"), allow_nan=False) + "\n").encode("utf-8")


@dataclass
class ReadResult:
    rows: list[ResultRow] = field(default_factory=list)
    torn_tail: bool = False
    bad_lines: int = 0

    def latest(self) -> dict[str, ResultRow]:
        """The last row of every id (later rows supersede earlier ones)."""
        out: dict[str, ResultRow] = {}
        for row in self.rows:
            out[row.id] = row
        return out


def read_rows(path: str | Path) -> ReadResult:
    """All whole rows of a runs file; a torn last line and unreadable lines (not JSON, or not a
    result row) are skipped (counted)."""
    path = Path(path)
    out = ReadResult()
    if not path.exists():
        return out
    data = path.read_bytes()
    lines = data.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    elif lines:
        lines.pop()
        out.torn_tail = True
    for raw in lines:
        if not raw.strip():
            continue
        try:
            out.rows.append(ResultRow.from_json(json.loads(raw)))
        except (json.JSONDecodeError, UnicodeDecodeError, DecodeError):
            out.bad_lines += 1
    return out


def repair(path: str | Path) -> int:
    """Cut a torn last line (bytes after the last newline); returns the number of bytes removed."""
    path = Path(path)
    if not path.exists():
        return 0
    size = path.stat().st_size
    if size == 0:
        return 0
    with open(path, "rb+") as fh:
        # scan back from the end for the last newline, in blocks
        pos, block = size, 65536
        keep = 0
        while pos > 0:
            start = max(0, pos - block)
            fh.seek(start)
            chunk = fh.read(pos - start)
            idx = chunk.rfind(b"\n")
            if idx >= 0:
                keep = start + idx + 1
                break
            pos = start
        if keep < size:
            fh.truncate(keep)
            fh.flush()
            os.fsync(fh.fileno())
        return size - keep


def _named(exc: OSError, path: Path) -> OSError:
    """``exc`` with the file it happened on, if it did not say (errors from ``write``/``fsync``)."""
    if exc.filename is not None or exc.errno is None:
        return exc
    return type(exc)(exc.errno, exc.strerror, str(path))


class RunStore:
    """Append-only writer of one campaign directory."""

    def __init__(self, directory: str | Path):
        self.dir = Path(directory)
        self.path = self.dir / RUNS
        self._fd: int | None = None

    def open(self) -> int:
        """Create the directory, repair a torn tail, open for appending; returns bytes cut."""
        self.dir.mkdir(parents=True, exist_ok=True)
        cut = repair(self.path)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        return cut

    def append(self, row: ResultRow) -> None:
        """Write one row as one line, then fsync."""
        if self._fd is None:
            raise RuntimeError("RunStore.append before open")
        data = encode_row(row)
        view = memoryview(data)
        try:
            while view:
                n = os.write(self._fd, view)
                view = view[n:]
            os.fsync(self._fd)
        except OSError as exc:
            # a write on a descriptor names no file; a full disk must say which one it was
            raise _named(exc, self.path) from None

    def save_mcap(self, run_id: str, data: bytes) -> Path:
        """Store a run's recording as ``mcap/<run_id>.mcap`` (atomic, like the weights)."""
        mdir = self.dir / MCAP
        mdir.mkdir(parents=True, exist_ok=True)
        final = mdir / f"{run_id}.mcap"
        tmp = mdir / f".{run_id}.tmp.mcap"
        try:
            with open(tmp, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:
            raise _named(exc, tmp) from None
        os.replace(tmp, final)
        return final

    def save_weights(self, run_id: str, histories: dict[str, RunWeights]) -> list[Path]:
        """Store each network's weight history as ``weights/<network>/<run_id>.npz`` (atomic)."""
        paths = []
        for network, history in histories.items():
            wdir = self.dir / WEIGHTS / network
            wdir.mkdir(parents=True, exist_ok=True)
            final = wdir / f"{run_id}.npz"
            tmp = wdir / f".{run_id}.tmp.npz"
            try:
                history.save(tmp)
                with open(tmp, "rb") as fh:
                    os.fsync(fh.fileno())
            except OSError as exc:
                raise _named(exc, tmp) from None
            os.replace(tmp, final)
            paths.append(final)
        return paths

    def read(self) -> ReadResult:
        return read_rows(self.path)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> "RunStore":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def load_weights(directory: str | Path, run_id: str, network: str) -> RunWeights:
    """One network's stored weight history of one run (see :meth:`RunStore.save_weights`)."""
    return RunWeights.load(Path(directory) / WEIGHTS / network / f"{run_id}.npz")


def has_weights(directory: str | Path, run_id: str, network: str) -> bool:
    return (Path(directory) / WEIGHTS / network / f"{run_id}.npz").is_file()


def write_json_atomic(path: str | Path, obj: Any) -> None:
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(_clean(obj), indent=1, allow_nan=False) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def write_text_atomic(path: str | Path, text: str) -> None:
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)

"""Output paths checked before anything starts, and write errors named by their file.

A command that would write into a directory it cannot create or write (read-only file system,
a path through a regular file, a full disk) says so in one line before starting — naming the
option, the path and the errno — and exits with code 2, instead of failing after minutes of
work. ``os.access`` cannot tell: it answers yes to root on a read-only mount. So the check
creates the directory and writes (then removes) a small file in it: whatever stops that stops
the real output too.
"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path

from tools.commands.errors import UsageError


def errno_text(exc: OSError) -> str:
    """``[Errno 28] No space left on device`` — the errno without the file name (the caller
    names the file, which an error from ``write`` or ``flush`` does not carry)."""
    if exc.errno is not None and exc.strerror:
        return f"[Errno {exc.errno}] {exc.strerror}"
    return str(exc) or exc.__class__.__name__


def write_error_line(exc: OSError, path: str | os.PathLike | None = None) -> str:
    """One line naming the file and the errno. An error that names its own file (``open``) is
    ``FILE: [Errno N] text``; one that does not (``write``, ``flush``) happened while writing
    ``path``, the file the caller was writing: ``PATH: cannot write: [Errno N] text``."""
    if exc.filename is not None:
        return f"{os.fspath(exc.filename)}: {errno_text(exc)}"
    return f"{os.fspath(path)}: cannot write: {errno_text(exc)}" if path is not None else errno_text(exc)


def _write_test(directory: Path) -> None:
    if directory.exists() and not directory.is_dir():
        # mkdir(exist_ok=True) would say "File exists", which hides what is wrong
        raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR))
    directory.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".navbank-write-test-", dir=directory)
    try:
        # one real byte: a full file system accepts the empty file but not its first block
        os.write(fd, b"\n")
        os.fsync(fd)
    finally:
        os.close(fd)
        os.unlink(tmp)


def check_output_dir(path: str | os.PathLike, option: str = "--out") -> Path:
    """Create ``path`` (with its parents) and prove it writable; UsageError (exit 2) otherwise."""
    p = Path(path)
    try:
        _write_test(p)
    except OSError as exc:
        raise UsageError(f"{option} {os.fspath(path)}: cannot write: {errno_text(exc)}") from None
    return p


def check_output_file(path: str | os.PathLike, option: str = "--out") -> Path:
    """Prove that file ``path`` can be written: its directory (created if missing) takes a file
    and the path itself is not a directory; UsageError (exit 2) otherwise. The file itself is
    left alone until the command writes it."""
    p = Path(path)
    try:
        if p.is_dir():
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR))
        _write_test(p.parent)
        if p.exists() and not os.access(p, os.W_OK):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))
    except OSError as exc:
        raise UsageError(f"{option} {os.fspath(path)}: cannot write: {errno_text(exc)}") from None
    return p


def emit_json(result: object, out: str | os.PathLike | None) -> None:
    """A command's JSON result: to ``out`` (already checked writable) when given, and to stdout."""
    import json
    import sys

    text = json.dumps(result, indent=2)
    if out:
        with open(out, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
    sys.stdout.write(text + "\n")


def write_json(data: object, path: Path) -> Path:
    """``data`` as indented JSON in ``path``, whole or not at all (written aside, then renamed)."""
    import json

    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=False) + "\n", encoding="utf-8")
    os.replace(tmp, path)
    return path

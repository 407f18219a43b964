"""Progress on the console: percentage, counts, elapsed time and ETA, drawn by tqdm.

On a terminal the bar is redrawn in place a few times a second. When the stream is a file or a
pipe (CI logs, a process's log file) each redraw becomes its own line, at most one every
``LOG_INTERVAL_S``, so logs stay readable and never hold carriage returns.
"""

from __future__ import annotations

import re
import shutil
import sys
from typing import Any, TextIO

from tqdm import tqdm

#: One layout for every bar: "label  56%|#####     | 25.2/45.0 day [elapsed 00:10, ETA 00:08, …]".
BAR_FORMAT = "{desc} {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {unit} [elapsed {elapsed}, ETA {remaining}{postfix}]"
LOG_INTERVAL_S = 10.0


class _Lines:
    """A stream that turns tqdm's in-place redraws into whole lines (repeats dropped)."""

    def __init__(self, stream: TextIO):
        self.stream = stream
        self._last = ""

    def write(self, text: str) -> int:
        for part in text.replace("\r", "\n").split("\n"):
            part = part.strip()
            if part and part != self._last:
                self.stream.write(part + "\n")
                self._last = part
        return len(text)

    def flush(self) -> None:
        self.stream.flush()


def progress_bar(total: float, *, desc: str, unit: str, stream: TextIO | None = None,
                 disable: bool = False) -> tqdm:
    """A bar over ``total`` units (a float total is fine: simulated days)."""
    stream = stream if stream is not None else sys.stderr
    tty = bool(getattr(stream, "isatty", lambda: False)())
    out: Any = stream if tty else _Lines(stream)
    # a terminal that reports no height (a pty made by `script`, some CI runners) would make tqdm
    # hide the bar as if it were below the screen: say there are lines (the width is read once)
    rows = max(shutil.get_terminal_size().lines, 2) if tty else None
    return tqdm(total=total, desc=desc, unit=unit, file=out, bar_format=BAR_FORMAT, disable=disable,
                mininterval=0.25 if tty else LOG_INTERVAL_S, ncols=None if tty else 140,
                nrows=rows, ascii=not tty, leave=True)


def advance_to(bar: tqdm, n: float, postfix: str | None = None) -> None:
    """Move ``bar`` to ``n`` (an absolute position, not an increment), with an optional note."""
    n = min(round(float(n), 1), bar.total) if bar.total else float(n)
    if postfix is not None:
        bar.set_postfix_str(postfix, refresh=False)
    if n > bar.n:
        bar.update(n - bar.n)
    # tqdm keeps float sums; keep the shown count tidy
    bar.n = n


# The flight software's progress line (fsw.app): "fsw: day  25.0  processed 1234  rejected 0 ...".
_FSW_LINE = re.compile(r"^fsw: day\s+(?P<day>[0-9]+(?:\.[0-9]+)?)\s+(?P<rest>.*?)\s*$")


def fsw_progress(line: str) -> tuple[float, str] | None:
    """(simulated day, the rest) of the FSW's progress line, or None for any other line."""
    m = _FSW_LINE.match(line)
    if m is None:
        return None
    rest = re.sub(r"\s{2,}", ", ", m.group("rest"))
    return float(m.group("day")), rest

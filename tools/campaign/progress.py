"""A one-line progress bar with throughput and ETA on stderr (plain text, no dependency).

On a terminal the line is redrawn in place (carriage return) at most a few times a second; when
stderr is a file or a pipe (CI logs) a line is written per finished run instead, so logs stay
readable.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


def format_duration(seconds: float | None) -> str:
    if seconds is None or seconds != seconds or seconds < 0:
        return "--:--"
    s = int(round(seconds))
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:02d}:{s:02d}"


class ProgressLine:
    """Counts finished/failed runs of this session and draws the bar."""

    def __init__(self, total: int, *, label: str = "", stream: TextIO | None = None, width: int = 24,
                 min_interval_s: float = 0.25, clock=time.monotonic):
        self.total = total
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.min_interval_s = min_interval_s
        self.clock = clock
        self.t0 = clock()
        self.done = 0
        self.failed = 0
        self.running = 0
        self.note = ""
        self._last_draw = -1e9
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._drawn = False

    def eta_s(self) -> float | None:
        """Remaining time at this session's mean throughput (None before the first run ends)."""
        if self.done == 0:
            return None
        rate = self.done / max(self.clock() - self.t0, 1e-9)
        return (self.total - self.done) / rate

    def rate_per_min(self) -> float:
        return 60.0 * self.done / max(self.clock() - self.t0, 1e-9)

    def text(self) -> str:
        frac = self.done / self.total if self.total else 1.0
        filled = int(round(frac * self.width))
        bar = "#" * filled + "-" * (self.width - filled)
        parts = [f"{self.label} " if self.label else "", f"[{bar}] {self.done}/{self.total}"]
        if self.failed:
            parts.append(f" ({self.failed} failed)")
        parts.append(f" | {self.running} running | {self.rate_per_min():.1f} runs/min")
        parts.append(f" | elapsed {format_duration(self.clock() - self.t0)} | ETA {format_duration(self.eta_s())}")
        if self.note:
            parts.append(f" | {self.note}")
        return "".join(parts)

    def update(self, *, finished: int = 0, failed: int = 0, running: int | None = None, note: str | None = None,
               force: bool = False) -> None:
        self.done += finished
        self.failed += failed
        if running is not None:
            self.running = running
        if note is not None:
            self.note = note
        now = self.clock()
        if self._tty:
            if force or finished or now - self._last_draw >= self.min_interval_s:
                self.stream.write("\r\x1b[2K" + self.text())
                self.stream.flush()
                self._last_draw = now
                self._drawn = True
        elif force or finished or note:
            self.stream.write(self.text() + "\n")
            self.stream.flush()

    def close(self) -> None:
        if self._tty and self._drawn:
            self.stream.write("\n")
            self.stream.flush()

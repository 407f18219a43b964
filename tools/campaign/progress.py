"""A campaign's progress: runs finished of those to run, failures, runs in flight, ETA.

The bar is :func:`tools.progress.progress_bar` (tqdm): redrawn in place on a terminal, a line
per change when stderr is a file or a pipe.
"""

from __future__ import annotations

from typing import TextIO

from tools.progress import progress_bar


class CampaignProgress:
    """Counts finished/failed runs of this session and keeps the bar's note current."""

    def __init__(self, total: int, *, label: str = "", stream: TextIO | None = None):
        self.bar = progress_bar(total, desc=label or "campaign", unit="runs", stream=stream)
        self.failed = 0
        self.running = 0
        self.note = ""

    def _postfix(self) -> str:
        parts = [f"{self.running} running"]
        if self.failed:
            parts.append(f"{self.failed} failed")
        if self.note:
            parts.append(self.note)
        return ", ".join(parts)

    def update(self, *, finished: int = 0, failed: int = 0, running: int | None = None, note: str | None = None,
               force: bool = False) -> None:
        self.failed += failed
        if running is not None:
            self.running = running
        if note is not None:
            self.note = note
        self.bar.set_postfix_str(self._postfix(), refresh=False)
        if finished:
            self.bar.update(finished)
        elif force or note:
            self.bar.refresh()

    def close(self) -> None:
        self.bar.close()

"""Python's cyclic garbage collector in a navbank process: off during start-up, and kept off
what start-up made.

A process of a run imports numpy, scipy, numba, zenoh and the project (~125k tracked objects in
the FSW process) and then works for minutes on short-lived messages. Measured on the default
scenario's FSW process (``navbank run``): the collector took 0.27 s of its 6.4 s of CPU — three
full passes over the imports (136 ms), and 532 passes over the young generation at Python's
threshold of 700 allocations (103 ms; the core holds it off inside frames, so each pass then
finds a frame's worth of objects). With the collector off while the process starts, what it made
frozen (:func:`gc.freeze`: never scanned again) and the young generation collected every
:data:`YOUNG_THRESHOLD` allocations, it took 6 ms, and the process's CPU fell from 6.4–6.8 s to
6.0–6.2 s (three runs each: the passes also cost the core the caches they swept). The launcher's
collections fell from 0.38 to 0.11 s. Start-up leaves almost no cyclic garbage (imports and
configuration are kept for the process's life), so none is collected there.

Only a process's own command line does this (:func:`tools.cli.main` without ``argv``): a test
or a tool calling :func:`tools.cli.main` in its own process keeps its collector as it was.
"""

from __future__ import annotations

import gc

#: Net allocations between passes over the young generation (Python's default: 700). Objects
#: that die by reference counting before a pass are never scanned, so rarer passes scan less.
YOUNG_THRESHOLD = 5000


def starting() -> None:
    """The process starts: no collection until :func:`started`."""
    gc.disable()


def started() -> None:
    """Start-up is over: what exists now is kept out of every later pass; collection resumes."""
    gc.freeze()
    gc.set_threshold(YOUNG_THRESHOLD, *gc.get_threshold()[1:])
    gc.enable()

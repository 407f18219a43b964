"""Results that spawned test processes put on a queue, collected with a deadline."""

from __future__ import annotations

import queue
import time


def collect_results(out, n: int, procs, timeout_s: float = 90.0) -> dict:
    """``n`` ``(kind, value)`` results from the children, failing at once if one of them dies."""
    results: dict = {}
    deadline = time.monotonic() + timeout_s
    while len(results) < n:
        assert time.monotonic() < deadline, f"timed out; got {sorted(results)}"
        try:
            kind, value = out.get(timeout=0.5)
            results[kind] = value
        except queue.Empty:
            dead = [p.name for p in procs if p.exitcode not in (None, 0)]
            if dead and out.empty():
                for p in procs:
                    p.kill()
                raise AssertionError(f"{', '.join(dead)} failed")
    return results

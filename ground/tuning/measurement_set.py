"""The measurement set a tuning command post-processes, read from a recorded run.

A recording holds ICD ``Measurement`` messages on ``/sim/measurements``; the linear tracking bank
takes the ``generic-linear`` ones (2 components: range, velocity), in sequence-number order.
"""

from __future__ import annotations

import os

import numpy as np

from fsw.interface import topics
from ground.mcap_io.reader import read_messages

KIND = "generic-linear"


def linear_measurements(path: str | os.PathLike) -> np.ndarray:
    """(K, 2) values of the recording's ``generic-linear`` measurements, by sequence number
    (a duplicated sequence number keeps its first copy). Raises ValueError if there are none."""
    seen: dict[int, tuple[float, ...]] = {}
    other = 0
    for m in read_messages(path, topics.SIM_MEASUREMENTS, strict=False):
        msg = m.message
        if getattr(msg, "kind", None) != KIND or len(getattr(msg, "value", ())) != 2:
            other += 1
            continue
        seen.setdefault(int(msg.seq), tuple(msg.value))
    if not seen:
        raise ValueError(f"{os.fspath(path)}: no 2-component {KIND} measurements on /{topics.SIM_MEASUREMENTS} "
                         f"({other} other messages)")
    return np.array([seen[k] for k in sorted(seen)], dtype=float)

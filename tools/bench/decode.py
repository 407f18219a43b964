"""The decode row of ``navbank bench``: strict ICD decoding against plain ``json.loads``.

``icd-decode``: the simulator stream's measurement payloads (Doppler, range and optical; a fixed
sample of the three kinds without the simulator) decoded per second by :func:`strict_decoder` —
the FSW's own decoder, which validates every field (types, ranges, finiteness, sizes) — against
``json.loads`` of the same bytes, which validates nothing. The goal is absolute: ≥ 100,000
messages per second; the ratio (ours / json.loads) says what the strictness costs.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

from fsw.interface import codec, messages as m
from tools.bench.rows import Goal, make_row

DECODE_GOAL = Goal("rate", ">=", 100_000.0, on="ours", unit="msg/s")


def strict_decoder() -> Callable[[bytes], Any]:
    """The decoder the FSW process runs on a received measurement payload (the one place the
    bench names it)."""
    return lambda payload: codec.from_json(m.Measurement, payload)


def sample_payloads() -> list[bytes]:
    """Encoded measurements of the three kinds, in the simulator's proportions (mostly Doppler)."""
    t = 596_000_000.0
    msgs = []
    for k in range(20):
        tk = t + 60.0 * k
        stamp = m.Stamp.from_unix(tk + 946_727_935.816)
        if k % 10 == 5:
            msgs.append(m.Measurement(seq=k, t_s=tk, timestamp=stamp, kind="range", source="DSS-14",
                                      value=(1.2345678901234e8,), sigma=(1e-3,)))
        elif k % 10 == 9:
            msgs.append(m.Measurement(seq=k, t_s=tk, timestamp=stamp, kind="optical", source="phobos",
                                      value=(512.25, 498.75), sigma=(0.3, 0.3),
                                      attitude_q=(0.5, 0.5, -0.5, 0.5)))
        else:
            msgs.append(m.Measurement(seq=k, t_s=tk, timestamp=stamp, kind="doppler", source="DSS-43",
                                      value=(-3.2109876543e0,), sigma=(1e-7,), count_time_s=60.0))
    return [codec.to_json(msg) for msg in msgs]


def _rate(fn: Callable[[bytes], Any], payloads: list[bytes], seconds: float) -> float:
    """Messages per second, best of repeated passes over ``payloads`` for about ``seconds``."""
    best = float("inf")
    deadline = time.perf_counter() + seconds
    while True:
        t0 = time.perf_counter()
        for p in payloads:
            fn(p)
        best = min(best, (time.perf_counter() - t0) / len(payloads))
        if time.perf_counter() > deadline:
            return 1.0 / best


def bench_decode(seconds: float = 1.0, measurements: tuple | None = None, label: str = "") -> dict[str, Any]:
    """Strict decoding rate of ``measurements`` (default: :func:`sample_payloads`) vs json.loads."""
    payloads = [codec.to_json(msg) for msg in measurements] if measurements else sample_payloads()
    decode = strict_decoder()
    ours = ref = 0.0
    for _ in range(3):  # interleaved
        ours = max(ours, _rate(decode, payloads, seconds / 6))
        ref = max(ref, _rate(json.loads, payloads, seconds / 6))
    return make_row("icd-decode", ours, ref, "msg/s", DECODE_GOAL,
                    "ours / json.loads of the same payloads (what validating every field costs)",
                    messages_per_s=ours, messages=len(payloads), mean_bytes=sum(map(len, payloads)) / len(payloads),
                    reference_impl="json.loads of the same payloads (no validation)",
                    stream=label or "a fixed sample of the three kinds")


__all__ = ["bench_decode", "strict_decoder", "sample_payloads"]

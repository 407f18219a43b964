"""Poison measurements change nothing but the rejection counters.

The same four-day run (the golden insight scenario: large optical bias, five gating networks, a
detector that declares) flown twice through the FSW core: once clean, once with the hostile
measurements that used to blind, hang or kill the FSW slipped into the stream. Every weight,
estimate, budget report and anomaly report must be identical; the status counters may differ
only by the rejections.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from fsw.core import FswCore
from fsw.interface import codec, messages as m
from sim.stream import generate
from tools.scenario import load_scenario, resolve

GOLDEN = Path(__file__).resolve().parent / "golden" / "insight-4day.yaml"
DAY = 86400.0

pytestmark = pytest.mark.slow


def _fly(cfg, items) -> list[tuple[str, object]]:
    out: list[tuple[str, object]] = []
    core = FswCore(cfg.fsw, lambda topic, msg: out.append((topic, msg)), run_id="poison")
    core.start()
    for item in items:
        if isinstance(item, bytes):
            core.ingest_payload(item)
        else:
            core.ingest(item)
    core.finish()
    return out


def test_poison_measurements_change_only_the_rejection_counters():
    cfg, seed = resolve(load_scenario(str(GOLDEN)))
    good = generate(cfg.sim, seed=seed).measurements
    k = len(good) // 3
    nxt = good[k]
    huge = json.loads(codec.to_json(nxt))
    huge["value"] = huge["sigma"] = [1.0] * 1_000_000
    poison = [
        dataclasses.replace(nxt, t_s=nxt.t_s + 60 * DAY),  # the next valid sequence number, 60 days ahead
        dataclasses.replace(nxt, t_s=1e300),
        dataclasses.replace(nxt, seq=2**62),
        dataclasses.replace(nxt, seq=10**7),
        json.dumps(huge).encode(),  # a 10^6-element value
    ]
    clean = _fly(cfg, good)
    dirty = _fly(cfg, [*good[:k], *poison, *good[k:]])

    def telemetry(run):
        return [(t, codec.to_json(msg)) for t, msg in run if t != "fsw/status"]

    assert telemetry(dirty) == telemetry(clean)
    assert any(t == "fsw/anomaly" and msg.flag for t, msg in clean)  # the run does declare
    end_clean = [msg for t, msg in clean if t == "fsw/status"][-1]
    end_dirty = [msg for t, msg in dirty if t == "fsw/status"][-1]
    assert isinstance(end_dirty, m.RunStatus) and end_dirty.state == "end-of-run"
    differ = {k for k in end_clean.counts.keys() | end_dirty.counts.keys()
              if end_clean.counts.get(k) != end_dirty.counts.get(k)}
    assert differ == {"received", "rejected", "rejected_future", "rejected_sequence_jump", "decode_errors"}
    c = end_dirty.counts
    assert (c["rejected_future"], c["rejected_sequence_jump"], c["decode_errors"]) == (2, 2, 1)
    assert c["received"] == end_clean.counts["received"] + 4
    assert c["lost"] == 0 and c["time_reversed"] == 0 and c["processed"] == end_clean.counts["processed"]

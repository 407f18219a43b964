"""Raw payloads into the FSW core: one by one, or several taken together (decoded first, then
ingested in turn) — the same run either way."""

from __future__ import annotations

import pytest

from fsw.core import FswCore
from fsw.interface import codec, topics
from sim.stream import generate
from tools.scenario import load_text_scenario, resolve

# work units: a CPU-metered budget would make the budget reports differ from run to run
SCENARIO = """\
name: payloads
seed: 5
sim:
  trajectory: {span_days: 1.0}
fsw:
  budget: {mode: work-units, work_unit_budget: 8.0}
  gating:
    - {network: chi2, batch_size: 100}
    - {network: chi2-two-sided, batch_size: 100}
    - {network: magill, lower_bound: 1.0e-12}
    - {network: moe, features: kind, kinds: [range, doppler, optical]}
"""


@pytest.fixture(scope="module")
def stream():
    cfg, seed = resolve(load_text_scenario(SCENARIO))
    payloads = [codec.to_json(meas) for meas in generate(cfg.sim, seed=seed).measurements]
    k = len(payloads) // 2
    good = payloads[k]
    wrong_schema = good.replace(b'"kind":"', b'"kind":"x', 1)
    # malformed ones in the middle of a run of payloads: counted where they stand
    return cfg, [*payloads[:k], b"\x00garbage", wrong_schema, *payloads[k:]]


def _fly(cfg, payloads, chunks):
    out: list[tuple[str, object]] = []
    core = FswCore(cfg.fsw, lambda topic, msg: out.append((topic, msg)), run_id="payloads")
    core.start()
    i = 0
    for n in chunks:
        if i >= len(payloads):
            break
        if n == 1:
            core.ingest_payload(payloads[i])
        else:
            core.ingest_payloads(payloads[i:i + n])
        i += n
    assert i >= len(payloads)
    end = core.finish()
    return core, out, end


def test_payloads_taken_together_fly_as_they_do_one_by_one(stream):
    cfg, payloads = stream
    one, out_one, end_one = _fly(cfg, payloads, [1] * len(payloads))
    sizes = [1, 2, 7, 32, 3, 9, 5]
    chunks = [sizes[j % len(sizes)] for j in range(len(payloads))]
    together, out_together, end_together = _fly(cfg, payloads, chunks)

    def telemetry(run):
        return [(t, codec.to_json(msg)) for t, msg in run if t != topics.FSW_STATUS]

    assert len(out_one) > 1000
    assert telemetry(out_together) == telemetry(out_one)
    assert together.taken == one.taken == len(payloads)
    assert together.counters.decode_errors == one.counters.decode_errors == 2
    counted = ("processed", "rejected", "decode_errors", "pending", "backlog")
    assert {k: end_together.counts[k] for k in counted} == {k: end_one.counts[k] for k in counted}
    assert end_one.counts["decode_errors"] == 2

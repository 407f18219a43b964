"""The whole-count Doppler step (one compiled call) against the bank's step by step path, to the bit."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import fsw.filters.radiometric_kinds as rk
from fsw.filters.bank import FilterBank
from fsw.filters.presets import preset
from fsw.kernels.doppler_step import doppler_step
from fsw.models.environment import Environment
from tools.bench.synthetic import make_run


@pytest.fixture(scope="module")
def run():
    return make_run(span_days=2.0, max_measurements=400, env=Environment())


def _bank(run, name: str) -> FilterBank:
    rng = np.random.default_rng(3)
    return FilterBank(preset(name), run.t0, run.position_km + rng.normal(0, 20.0, 3),
                      run.velocity_km_s + rng.normal(0, 2e-5, 3), env=Environment())


def _fly(run, name: str, commands, monkeypatch, fused: bool):
    statuses: Counter[str] = Counter()
    with monkeypatch.context() as mp:
        if fused:
            def counted(*args):
                status = doppler_step(*args)
                statuses["done" if status == 0 else "leg only"] += 1
                return status
            mp.setattr(rk, "doppler_step", counted)
        else:
            mp.setattr(rk.DopplerModel, "step", lambda self, *args: None)
        bank = _bank(run, name)
        records = []
        for k, m in enumerate(run.measurements):
            for at, apply in commands:
                if at == k:
                    apply(bank)
            records.append(bank.process(m))
    return bank, records, statuses


@pytest.mark.parametrize("name, commands", [
    ("nominal", []),
    ("acs-q", []),  # six filters, stochastic batches (the leg splits at their boundaries)
    ("nominal", [(60, lambda b: b.set_param("radio", "gate_chi2", 1.0)),  # editing in the step
                 (120, lambda b: b.set_enabled("fused", False)),
                 (200, lambda b: b.set_enabled("fused", True)),
                 (220, lambda b: b.set_param("radio", "sigma_scale.doppler", 1.7))]),
])
def test_the_compiled_count_step_gives_the_step_by_step_results_to_the_bit(run, monkeypatch, name, commands):
    bank_a, recs_a, statuses = _fly(run, name, commands, monkeypatch, fused=True)
    bank_b, recs_b, _ = _fly(run, name, commands, monkeypatch, fused=False)
    dopplers = sum(m.kind == "doppler" for m in run.measurements)
    # most counts went through the compiled step, and some needed another station node half way
    assert statuses["done"] > 0.6 * dopplers and statuses["leg only"] > 0, statuses
    for a, b in zip(recs_a, recs_b):
        assert (a.t, a.seq, a.kind) == (b.t, b.seq, b.kind)
        for field in ("residual", "S", "chi2", "processed", "active"):
            assert np.array_equal(getattr(a, field), getattr(b, field)), (a.seq, field)
    assert bank_a.t == bank_b.t
    assert np.array_equal(bank_a.stack.x, bank_b.stack.x) and np.array_equal(bank_a.stack.P, bank_b.stack.P)
    if commands:
        assert any(not r.processed[0] for r in recs_a[60:] if r.kind == "doppler")  # the gate edited some


def test_the_step_leaves_counts_it_cannot_take_to_the_bank(run):
    """A count that does not span the leg from the bank's epoch is not the step's: None, bank untouched."""
    bank = _bank(run, "nominal")
    first = next(m for m in run.measurements if m.kind == "doppler")
    stack = bank.stack
    x, P, t = stack.x.copy(), stack.P.copy(), stack.t
    scale = np.ones(len(bank.names))
    out = rk.doppler_count_step(stack, first.source, first.t_s + 10.0 * first.count_time_s, first.count_time_s,
                                np.array(first.value), first.sigma[0], scale, np.ones(len(bank.names), dtype=bool),
                                np.full(len(bank.names), np.inf))
    assert out is None and stack.t == t and np.array_equal(stack.x, x) and np.array_equal(stack.P, P)

"""The compiled radiometric steps against the bank's step by step path, to the bit. Doppler counts
that span the leg just flown, counts that began before it (a range measurement came between),
counts at the epoch the bank is at already, spanning the leg that brought it there or begun
before it; range measurements; and both kinds with transmit epochs that need another station
node, or the first node of a station's pass."""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
import pytest

import fsw.filters.radiometric_kinds as rk
from fsw.filters.bank import FilterBank
from fsw.filters.presets import preset
from fsw.kernels.radiometric_step import doppler_finish, doppler_step, range_finish, range_step
from fsw.models.environment import Environment
from sim.config import SimConfig
from sim.stream import generate
from tools.bench.synthetic import make_run


@dataclass(frozen=True)
class Stream:
    t0: float
    position_km: np.ndarray
    velocity_km_s: np.ndarray
    measurements: tuple


#: What each stream exercises: the synthetic one has a range measurement between Doppler counts
#: (and a station node boundary), the simulator's a range measurement at a count's time tag. In
#: each, the first measurement of some station's pass finds the last light-time solution another
#: station's: the step then has no node at all and looks it up after the reception epochs.
CASES = {
    "synthetic": ("leg flown, start from it", "leg flown, start propagated back", "another station node",
                  "first of a pass"),
    "simulator": ("leg flown, start from it", "leg held, start from it", "range: first of a pass"),
    # no count in the 20 minutes before every fourth range: its transmit epoch is past the last node's reach
    "synthetic with gaps": ("range: another station node", "first of a pass", "range: first of a pass"),
}


@pytest.fixture(scope="module")
def streams() -> dict[str, Stream]:
    synthetic = make_run(span_days=2.0, max_measurements=400, env=Environment())
    cfg = SimConfig()
    sim = generate(dataclasses.replace(cfg, trajectory=dataclasses.replace(cfg.trajectory, span_days=2.0)), seed=1)
    truth = sim.truth_at(sim.t_start)
    ranges = [m.t_s for m in synthetic.measurements if m.kind == "range"][::4]
    gaps = tuple(m for m in synthetic.measurements
                 if m.kind != "doppler" or not any(0.0 <= t - m.t_s < 1200.0 for t in ranges))
    return {"synthetic": Stream(synthetic.t0, synthetic.position_km, synthetic.velocity_km_s, synthetic.measurements),
            "synthetic with gaps": Stream(synthetic.t0, synthetic.position_km, synthetic.velocity_km_s, gaps),
            "simulator": Stream(sim.t_start, np.array(truth.position_km), np.array(truth.velocity_km_s),
                                tuple(sim.measurements[:400]))}


def _bank(run, name: str) -> FilterBank:
    rng = np.random.default_rng(3)
    return FilterBank(preset(name), run.t0, run.position_km + rng.normal(0, 20.0, 3),
                      run.velocity_km_s + rng.normal(0, 2e-5, 3), env=Environment())


_PARAMETERS = list(inspect.signature(doppler_step.py_func).parameters)
_FLY, _FROM_LEG = _PARAMETERS.index("fly"), _PARAMETERS.index("from_leg")
_T_GRID = _PARAMETERS.index("t_grid")
_RANGE_T_GRID = list(inspect.signature(range_step.py_func).parameters).index("t_grid")


def _fly(run, name: str, commands, monkeypatch, fused: bool):
    statuses: Counter[str] = Counter()
    with monkeypatch.context() as mp:
        if fused:
            def counted(*args):
                status = doppler_step(*args)
                case = ("leg flown" if args[_FLY] else "leg held") + (", start from it" if args[_FROM_LEG] else
                                                                      ", start propagated back")
                statuses[case] += 1
                statuses["another station node"] += status
                statuses["first of a pass"] += args[_T_GRID] == -math.inf
                return status

            def finished(*args):
                statuses["finished"] += 1
                return doppler_finish(*args)

            def ranged(*args):
                status = range_step(*args)
                statuses["range"] += 1
                statuses["range: another station node"] += status
                statuses["range: first of a pass"] += args[_RANGE_T_GRID] == -math.inf
                return status

            def range_finished(*args):
                statuses["range finished"] += 1
                return range_finish(*args)
            mp.setattr(rk, "doppler_step", counted)
            mp.setattr(rk, "doppler_finish", finished)
            mp.setattr(rk, "range_step", ranged)
            mp.setattr(rk, "range_finish", range_finished)
        else:
            mp.setattr(rk.DopplerModel, "step", lambda self, *args: None)
            mp.setattr(rk.RangeModel, "step", lambda self, *args: None)
        bank = _bank(run, name)
        records = []
        for k, m in enumerate(run.measurements):
            for at, apply in commands:
                if at == k:
                    apply(bank)
            records.append(bank.process(m))
    return bank, records, statuses


@pytest.mark.parametrize("stream", list(CASES))
@pytest.mark.parametrize("name, commands", [
    ("nominal", []),
    ("acs-q", []),  # six filters, stochastic batches (the leg splits at their boundaries)
    ("nominal", [(60, lambda b: b.set_param("radio", "gate_chi2", 1.0)),  # editing in the step
                 (120, lambda b: b.set_enabled("fused", False)),
                 (200, lambda b: b.set_enabled("fused", True)),
                 (220, lambda b: b.set_param("radio", "sigma_scale.doppler", 1.7))]),
])
def test_the_compiled_steps_give_the_step_by_step_results_to_the_bit(streams, monkeypatch, stream, name,
                                                                           commands):
    run = streams[stream]
    bank_a, recs_a, statuses = _fly(run, name, commands, monkeypatch, fused=True)
    bank_b, recs_b, _ = _fly(run, name, commands, monkeypatch, fused=False)
    dopplers = sum(m.kind == "doppler" for m in run.measurements)
    ranges = sum(m.kind == "range" for m in run.measurements)
    # nearly every count and range went through the compiled steps, by each of their ways
    compiled = sum(v for k, v in statuses.items() if k.startswith("leg"))
    assert compiled > 0.8 * dopplers and statuses["range"] > 0.8 * ranges > 0, (statuses, ranges)
    assert all(statuses[case] > 0 for case in CASES[stream]), statuses
    assert statuses["finished"] == statuses["another station node"], statuses
    assert statuses["range finished"] == statuses["range: another station node"], statuses
    for a, b in zip(recs_a, recs_b):
        assert (a.t, a.seq, a.kind) == (b.t, b.seq, b.kind)
        for field in ("residual", "S", "chi2", "processed", "active"):
            assert np.array_equal(getattr(a, field), getattr(b, field)), (a.seq, field)
    assert bank_a.t == bank_b.t
    assert np.array_equal(bank_a.stack.x, bank_b.stack.x) and np.array_equal(bank_a.stack.P, bank_b.stack.P)
    if commands:
        assert any(not r.processed[0] for r in recs_a[60:] if r.kind == "doppler")  # the gate edited some


def _two_legs(t1: float):
    """Bring the bank to ``t1`` in two legs, the last 10 s long, as an estimate epoch just before a
    time tag and a range measurement at it do in flight: a count ending at t1 then began before
    the leg that brought the bank there."""
    def apply(bank: FilterBank) -> None:
        bank.propagate_to(t1 - 10.0)
        bank.propagate_to(t1)
    return apply


def test_a_count_at_the_bank_epoch_that_began_before_its_last_leg_gives_the_step_by_step_results(streams,
                                                                                               monkeypatch):
    run = streams["simulator"]
    ms = run.measurements
    commands = [(k, _two_legs(m.t_s)) for k, m in enumerate(ms)
                if k % 5 == 0 and m.kind == "doppler" and k and ms[k - 1].t_s < m.t_s - 20.0]
    assert len(commands) > 20
    bank_a, recs_a, statuses = _fly(run, "nominal", commands, monkeypatch, fused=True)
    bank_b, recs_b, _ = _fly(run, "nominal", commands, monkeypatch, fused=False)
    assert statuses["leg held, start propagated back"] == len(commands), statuses
    for a, b in zip(recs_a, recs_b):
        for field in ("residual", "S", "chi2", "processed", "active"):
            assert np.array_equal(getattr(a, field), getattr(b, field)), (a.seq, field)
    assert np.array_equal(bank_a.stack.x, bank_b.stack.x) and np.array_equal(bank_a.stack.P, bank_b.stack.P)


def test_the_step_leaves_counts_it_cannot_take_to_the_bank(streams):
    """A count ending at the bank's epoch when an event (a stochastic batch boundary) is due there
    is not the step's: None, the bank untouched (the step by step path applies the event first)."""
    run = streams["synthetic"]
    bank = _bank(run, "nominal")
    ms = iter(run.measurements)
    first = next(m for m in ms if m.kind == "doppler" and bank.process(m) is not None)
    for m in ms:
        bank.process(m)
        if m.kind == "doppler":
            break
    stack = bank.stack
    assert stack.env.last_station_node(first.source) is not None  # the step would not refuse for want of it
    x, P, t = stack.x.copy(), stack.P.copy(), stack.t
    N = len(bank.names)
    stack._next_event = t  # an event due at the bank's epoch
    out = rk.doppler_count_step(stack, first.source, t, first.count_time_s, np.array(first.value), first.sigma[0],
                                np.ones(N), np.ones(N, dtype=bool), np.full(N, np.inf))
    assert out is None and stack.t == t and np.array_equal(stack.x, x) and np.array_equal(stack.P, P)

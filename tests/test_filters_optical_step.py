"""The compiled optical step against the bank's step by step path, to the bit: images after a leg,
images with the time tag of the measurement before them (nothing to fly), and images the camera
cannot take (target behind it), which both paths must reject alike."""

from __future__ import annotations

import dataclasses
import inspect
from collections import Counter

import numpy as np
import pytest

import fsw.filters.optical_kind as ok
from fsw.filters.bank import FilterBank
from fsw.filters.errors import MeasurementRejected
from fsw.filters.presets import preset
from fsw.kernels.codes import OK
from fsw.kernels.optical_step import optical_step
from fsw.models.environment import Environment
from sim.config import SimConfig
from sim.stream import generate

_FLY = list(inspect.signature(optical_step.py_func).parameters).index("fly")


def _turned(q: tuple[float, ...]) -> tuple[float, ...]:
    """The attitude turned half a turn about the camera's x axis: the boresight looks away."""
    w, x, y, z = q
    return (-x, w, -z, y)  # q ⊗ [0, 1, 0, 0]


@pytest.fixture(scope="module")
def stream():
    cfg = SimConfig()
    sim = generate(dataclasses.replace(cfg, trajectory=dataclasses.replace(cfg.trajectory, span_days=2.0)), seed=1)
    truth = sim.truth_at(sim.t_start)
    measurements = list(sim.measurements)
    optical = [k for k, m in enumerate(measurements) if m.kind == "optical"]
    for k in optical[3::7]:  # every seventh image taken looking away
        measurements[k] = dataclasses.replace(measurements[k], attitude_q=_turned(measurements[k].attitude_q))
    return sim.t_start, np.array(truth.position_km), np.array(truth.velocity_km_s), tuple(measurements)


def _cameras_varied(name: str):
    """The preset with the optical filter's camera seeing stellar aberration and the fused
    filter's without light time (every branch of the camera model in one bank)."""
    cfg = preset(name)
    filters = []
    for f in cfg.filters:
        if f.name == "optical":
            f = dataclasses.replace(f, camera=dataclasses.replace(f.camera, aberration=True))
        elif f.name == "fused":
            f = dataclasses.replace(f, camera=dataclasses.replace(f.camera, light_time=False, focal_length_mm=480.0))
        filters.append(f)
    return dataclasses.replace(cfg, filters=tuple(filters))


def _fly(stream, name: str, commands, monkeypatch, compiled: bool):
    t0, r0, v0, measurements = stream
    ways: Counter[str] = Counter()
    with monkeypatch.context() as mp:
        if compiled:
            def counted(*args):
                code = optical_step(*args)
                ways["leg flown" if args[_FLY] else "nothing to fly"] += 1
                ways["cannot image"] += code != OK
                return code
            mp.setattr(ok, "optical_step", counted)
        else:
            mp.setattr(ok.OpticalModel, "step", lambda self, *args: None)
        rng = np.random.default_rng(3)
        cfg = _cameras_varied(name[:-len(" cameras")]) if name.endswith(" cameras") else preset(name)
        bank = FilterBank(cfg, t0, r0 + rng.normal(0, 20.0, 3), v0 + rng.normal(0, 2e-5, 3),
                          env=Environment())
        outcomes = []
        for k, m in enumerate(measurements):
            for at, apply in commands:
                if at == k:
                    apply(bank)
            try:
                outcomes.append(bank.process(m))
            except MeasurementRejected as exc:
                outcomes.append(exc.reason)
    return bank, outcomes, ways


@pytest.mark.parametrize("name, commands", [
    ("nominal", []),
    ("acs-q", []),  # six filters, stochastic batches (legs that cross a boundary go step by step)
    ("nominal cameras", []),  # aberration (velocity partials), no light time, another focal length
    ("nominal", [(100, lambda b: b.set_param("optical", "gate_chi2", 2.0)),  # editing in the step
                 (300, lambda b: b.set_enabled("fused", False)),
                 (600, lambda b: b.set_enabled("fused", True)),
                 (700, lambda b: b.set_param("fused", "sigma_scale.optical", 1.7))]),
])
def test_the_compiled_optical_step_gives_the_step_by_step_results_to_the_bit(stream, monkeypatch, name, commands):
    bank_a, out_a, ways = _fly(stream, name, commands, monkeypatch, compiled=True)
    bank_b, out_b, _ = _fly(stream, name, commands, monkeypatch, compiled=False)
    images = sum(m.kind == "optical" for m in stream[3])
    # nearly every image went through the compiled step, by each of its ways
    assert ways["leg flown"] + ways["nothing to fly"] > 0.8 * images, ways
    assert all(ways[way] > 0 for way in ("leg flown", "nothing to fly", "cannot image")), ways
    rejected = [o for o in out_a if isinstance(o, str)]
    assert rejected.count("geometry") == ways["cannot image"] > 0
    assert len(out_a) == len(out_b)
    for a, b in zip(out_a, out_b):
        if isinstance(a, str) or isinstance(b, str):
            assert a == b
            continue
        assert (a.t, a.seq, a.kind) == (b.t, b.seq, b.kind)
        for field in ("residual", "S", "chi2", "processed", "active"):
            assert np.array_equal(getattr(a, field), getattr(b, field)), (a.seq, field)
    assert bank_a.rejected == bank_b.rejected
    assert bank_a.t == bank_b.t
    assert np.array_equal(bank_a.stack.x, bank_b.stack.x) and np.array_equal(bank_a.stack.P, bank_b.stack.P)
    if commands:
        optical = bank_a.names.index("optical")
        assert any(not o.processed[optical] for o in out_a[100:300] if not isinstance(o, str) and o.kind == "optical")

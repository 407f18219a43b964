"""Both filter banks satisfy the ``Bank`` protocol: statically (mypy) and at run time."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from fsw.filters.bank import FilterBank
from fsw.filters.linear import LinearFilterBank
from fsw.filters.presets import preset
from fsw.filters.protocol import Bank
from fsw.interface.messages import Measurement, Stamp
from fsw.models.environment import Environment
from tools.bench.synthetic import make_run

ROOT = Path(__file__).resolve().parents[1]


def as_bank(bank: FilterBank | LinearFilterBank) -> Bank:
    """Type-checked: mypy refuses this if either bank stops satisfying the protocol."""
    return bank


def _linear() -> LinearFilterBank:
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    return LinearFilterBank(["a", "b"], F, np.eye(2) * 1e-3, np.eye(2), np.eye(2), np.zeros(2), np.eye(2))


def _ekf() -> FilterBank:
    env = Environment()
    run = make_run(span_days=1.0, max_measurements=20, env=env)
    bank = FilterBank(preset("nominal"), run.t0, run.position_km, run.velocity_km_s, env=env)
    bank.process(run.measurements[0])
    return bank


def test_the_banks_satisfy_the_protocol_statically() -> None:
    api = pytest.importorskip("mypy.api")
    cache = os.environ.get("MYPY_CACHE_DIR", str(ROOT / ".mypy_cache"))
    stdout, stderr, status = api.run(["--config-file", str(ROOT / "pyproject.toml"), "--cache-dir", cache,
                                      "--no-error-summary", __file__])
    assert status == 0, stdout + stderr


@pytest.mark.parametrize("make", [_linear, _ekf])
def test_the_banks_satisfy_the_protocol_at_run_time(make) -> None:
    bank = as_bank(make())
    assert isinstance(bank, Bank)
    name = bank.names[-1]
    count = bank.processed_count
    bank.set_enabled(name, False)
    assert not bank.active[bank.index(name)]
    bank.set_enabled(name, True)
    t = bank.t + 60.0
    bank.propagate_to(t)
    assert bank.t == t and bank.processed_count == count
    ests = bank.estimates(np.full(len(bank.names), 1.0 / len(bank.names)))
    assert set(bank.names) | {"combined", "best"} == set(ests)
    assert all(e.x.shape == e.sigma.shape == (len(e.state_names),) for e in ests.values())


def test_the_linear_bank_processes_icd_measurements_through_the_protocol() -> None:
    bank = as_bank(_linear())
    rec = bank.process(Measurement(seq=0, t_s=1.0, timestamp=Stamp(0, 0), kind="generic-linear", source="track",
                                   value=(0.5, 0.1), sigma=(1.0, 1.0)))
    assert rec.filters == bank.names and bank.processed_count == 1 and not bank.rejected

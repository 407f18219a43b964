"""The linear actuator-failure case (Hanlon & Maybeck 2000) and the identification-time campaign."""

from __future__ import annotations

import numpy as np
import pytest

from sim.scenarios import actuator_dither as ad
from tools.validation.hanlon2000 import identification, run_hanlon2000


def test_the_oscillator_makes_the_dither_and_a_failed_actuator_drops_its_column():
    F = ad.transition(0, 1.0)
    s = np.zeros(ad.N_STATE)
    s[4::2] = 1.0
    sines = []
    for _ in range(40):
        sines.append(s[5::2].copy())
        s = F @ s
    k = np.arange(40)
    for j, f in enumerate(ad.FREQUENCIES):
        np.testing.assert_allclose(np.array(sines)[:, j], np.sin(2 * np.pi * f * k), atol=1e-12)
    for failed in (1, 2, 3):
        Ff = ad.transition(failed, 1.0)
        o = 4 + 2 * (failed - 1) + 1
        assert not Ff[0:4, o].any() and F[2:4, o].tolist() == (ad.DT * ad.B[:, failed - 1]).tolist()


def test_truth_follows_the_failed_model_after_the_failure():
    rng = np.random.default_rng(0)
    run = ad.generate(rng, 0.0, 2, 10, 30)  # zero dither: failure invisible, rates a random walk
    assert run.z.shape == (30, 4) and run.failed == 2 and run.fail_at == 10


def test_identification_rule():
    W = np.tile([0.97, 0.01, 0.01, 0.01], (400, 1))
    W[150:, :] = [0.01, 0.01, 0.97, 0.01]
    assert identification(W, 2, 100) == (50.0, False)
    W[20, :] = [0.01, 0.95, 0.02, 0.02]
    assert identification(W, 2, 100)[1] is True
    assert identification(W, 3, 100)[0] is None


@pytest.mark.slow
def test_residual_correlation_identifies_dithers_too_small_for_magill():
    r = run_hanlon2000(runs=3, multipliers=(1.0, 0.02))
    assert all(t is not None for t in r.time_s["magill"][1.0])
    assert all(t is not None for t in r.time_s["residual-correlation"][1.0])
    assert all(t is None for t in r.time_s["magill"][0.02])  # the magnitude-based bank never identifies
    assert sum(t is not None for t in r.time_s["residual-correlation"][0.02]) >= 2

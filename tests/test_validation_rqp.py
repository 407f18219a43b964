"""Chaer et al. 1997 §V.D (Experiment 4) through navbank's RQP adaptation: the qualitative findings."""

from __future__ import annotations

import numpy as np
import pytest

from tools.validation.chaer1997_rqp import experiment4_section, plot_experiment_4, run_experiment_4


@pytest.mark.slow
def test_experiment_4_adaptation_moves_toward_truth_and_lowers_error(tmp_path):
    r = run_experiment_4(runs=4)
    assert r.first_filter.count("KF1") >= 3  # the paper's best filter at t = 200 s
    D = np.array(r.distance)
    assert np.median(D[:, 1]) < 0.5 * np.median(D[:, 0])  # parameters move toward α*
    nll = np.array(r.nll)
    assert np.all(nll[:, :, 1] <= nll[:, :, 0])  # every adaptation raises the window's likelihood
    after = slice(1, None)
    assert np.mean(np.median(r.rms_adapted, axis=0)[after]) < np.mean(np.median(r.rms_fixed, axis=0)[after])
    s = experiment4_section(r, plot_experiment_4(r, tmp_path / "figures" / "e4.png"), tmp_path)
    assert all(c.holds for c in s.claims), [c.evidence for c in s.claims if not c.holds]

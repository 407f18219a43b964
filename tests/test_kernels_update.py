"""The compiled Joseph-form update against the numpy update it replaced (fsw.filters.kalman.update,
an independent evaluation of the same congruence), on random filters, gates and masks."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.filters import kalman
from fsw.kernels.joseph_update import joseph_update


def _case(rng: np.random.Generator, N: int, n: int, m: int):
    scale = 10.0 ** rng.uniform(-8, 2, n)
    A = rng.normal(size=(N, n, n)) * scale[None, :, None]
    P = A @ A.transpose(0, 2, 1) + np.diag(scale**2)[None]
    x = rng.normal(size=(N, n)) * scale
    H = rng.normal(size=(N, m, n)) / scale
    R = np.zeros((N, m, m))
    R[:, np.arange(m), np.arange(m)] = 10.0 ** rng.uniform(-3, 1, (N, m))
    residual = rng.normal(size=(N, m)) * 3.0
    does = rng.random(N) < 0.7
    gate = np.where(rng.random(N) < 0.5, np.inf, rng.uniform(1.0, 50.0, N))
    return x, P, H, R, residual, does, gate


@pytest.mark.parametrize("m", [1, 2])
@pytest.mark.parametrize("seed", range(5))
def test_joseph_kernel_matches_numpy_update(m, seed):
    rng = np.random.default_rng(100 * m + seed)
    N, n = 4, 16
    x, P, H, R, residual, does, gate = _case(rng, N, n, m)
    x_out, P_out = np.empty((N, n)), np.empty((N, n, n))
    S, chi2, processed = np.empty((N, m, m)), np.empty(N), np.empty(N, dtype=bool)
    # the kernel forms the residual y − h itself: hand it a prediction h that gives this one
    y = rng.normal(size=m) * 1e3
    h = y[None, :] - residual
    res_out = np.empty((N, m))
    joseph_update(x, P, H, R, y, h, does, gate, res_out, x_out, P_out, S, chi2, processed)
    assert np.array_equal(res_out, y[None, :] - h)
    residual = res_out

    Mt = kalman.augmented_joint(x, P, H, R, residual)
    PX, _, S_ref, chi2_ref, proc_ref = kalman.update(Mt, n, does, gate)
    assert np.array_equal(processed, proc_ref)
    assert np.allclose(S, S_ref, rtol=1e-13, atol=0.0)
    assert np.allclose(chi2, chi2_ref, rtol=1e-12, atol=0.0)
    d = np.sqrt(np.einsum("kii->ki", P))  # rounding is relative to the prior's scale
    assert np.max(np.abs(P_out - PX[:, :, :n]) / (d[:, :, None] * d[:, None, :])) < 1e-13
    assert np.max(np.abs(x_out + PX[:, :, n]) / d) < 1e-13
    # filters that do not update keep their prior exactly
    assert np.array_equal(x_out[~processed], x[~processed]) and np.array_equal(P_out[~processed], P[~processed])
    for i in np.flatnonzero(processed):
        assert kalman.is_spd(kalman.symmetrise(P_out[i]), rtol=1e-8)


def test_bank_covariances_stay_spd_over_a_run(short_scenario, tmp_path):
    """Every filter's P stays symmetric positive definite through a four-day run of compiled
    time and measurement updates (checked every 100 measurements and at the end)."""
    from fsw.core.fswcore import FswCore
    from fsw.filters.errors import MeasurementRejected
    from sim.stream import generate
    from tools.scenario import load_scenario, resolve

    path = tmp_path / "short.yaml"
    path.write_text(short_scenario(span_days=4.0))
    resolved, seed = resolve(load_scenario(str(path)), 3)
    run = generate(resolved.sim, seed=seed)
    bank = FswCore(resolved.fsw, lambda *a: None).bank
    done = 0
    for k, meas in enumerate(run.measurements):
        try:
            bank.process(meas)
            done += 1
        except MeasurementRejected:
            continue
        if k % 100 == 0 or k == len(run.measurements) - 1:
            for name in bank.names:
                assert kalman.is_spd(kalman.symmetrise(bank.P(name))), (k, name)
    assert done > 1000

"""The compiled count-start and Doppler kernels against the numpy arithmetic they replaced."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.astro.constants import C_KM_S
from fsw.kernels.count_start import count_start_from_leg
from fsw.kernels.doppler import doppler_prediction


def _reference_count_start(Y, z0, z1, z, q, q_leg):
    inv = np.empty((Y.shape[0], 6, 6))
    inv[:, 0:3, 0:3] = Y[:, 3:6, 3:6].transpose(0, 2, 1)
    inv[:, 0:3, 3:6] = -Y[:, 0:3, 3:6].transpose(0, 2, 1)
    inv[:, 3:6, 0:3] = -Y[:, 3:6, 0:3].transpose(0, 2, 1)
    inv[:, 3:6, 3:6] = Y[:, 0:3, 0:3].transpose(0, 2, 1)
    Yb = np.concatenate([inv, -inv @ Y[:, :, 6:]], axis=2)
    dz = np.concatenate([z - z1, q - q_leg], axis=1)
    return z0 + np.matmul(Yb, dz[:, :, None])[:, :, 0], Yb


@pytest.mark.parametrize("seed", range(4))
def test_count_start_kernel_matches_numpy(seed):
    rng = np.random.default_rng(seed)
    N, nq = 3, 4 + 3 * (seed % 3)
    Y = rng.normal(size=(N, 6, 6 + nq))
    z0, z1, z = (rng.normal(size=(N, 6)) * 1e3 for _ in range(3))
    q, q_leg = rng.normal(size=(N, nq)), rng.normal(size=(N, nq))
    z_start, Yb = np.empty((N, 6)), np.empty_like(Y)
    count_start_from_leg(Y, z0, z1, z, q, q_leg, z_start, Yb)
    z_ref, Yb_ref = _reference_count_start(Y, z0, z1, z, q, q_leg)
    assert np.allclose(Yb, Yb_ref, rtol=1e-14, atol=1e-14)
    assert np.allclose(z_start, z_ref, rtol=1e-13, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_doppler_kernel_matches_numpy(seed):
    rng = np.random.default_rng(seed)
    N, nq, T = 3, 4 + 3 * (seed % 2), 60.0
    n = 6 + nq + 3 + 1  # [r, v, parameters..., clock (3), range bias]
    c0, c1 = 6 + nq, 6 + nq + 3
    src = np.full(n, -1, dtype=np.int64)
    src[: 6 + nq] = np.arange(6 + nq)
    z_to_state = np.zeros((6 + nq, n))
    z_to_state[np.arange(6 + nq), np.arange(6 + nq)] = 1.0
    rho = rng.uniform(1e8, 3e8, (2, N))
    ku = rng.normal(size=(2, N, 3))
    d_rho_d_delta = rng.normal(size=(2, N)) * 30.0
    delta, freq, drift = rng.normal(size=N) * 1e-6, rng.normal(size=N) * 1e-12, rng.normal(size=N) * 1e-18
    Yb = rng.normal(size=(N, 6, 6 + nq))
    h, H = np.empty((N, 1)), np.empty((N, 1, n))
    x = rng.normal(size=(N, n))
    x[:, c0], x[:, c0 + 1], x[:, c0 + 2] = delta, freq, drift
    doppler_prediction(rho, ku, d_rho_d_delta, delta, Yb, src, x, T, c0, c1, C_KM_S, h, H)

    h_ref = (rho[0] - rho[1]) / T + C_KM_S * (freq - 0.5 * drift * T)
    g_start = np.concatenate([ku[1], -delta[:, None] * ku[1]], axis=1)
    d_start = np.matmul(g_start[:, None, :], Yb)[:, 0, :]
    d_end = np.zeros((N, 6 + nq))
    d_end[:, 0:3] = ku[0]
    d_end[:, 3:6] = -delta[:, None] * ku[0]
    H_ref = ((d_end - d_start) / T) @ z_to_state
    H_ref[:, c0] = (d_rho_d_delta[0] - d_rho_d_delta[1]) / T
    H_ref[:, c0 + 1] = C_KM_S
    H_ref[:, c0 + 2] = -0.5 * C_KM_S * T
    assert np.allclose(h[:, 0], h_ref, rtol=1e-15, atol=1e-9)
    assert np.allclose(H[:, 0], H_ref, rtol=1e-13, atol=1e-16)

"""The compiled RK4 + variational-equations kernel against the numpy propagator it replaced
(tests/reference_propagator.py, an independent evaluation of the same equations)."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.filters.config import BankConfig, FilterConfig, PolyAccelConfig
from fsw.filters.ekf import EKFStack
from fsw.models.environment import Environment
from reference_propagator import ReferencePropagator
from tools.bench.synthetic import entry_state

ENV = Environment()


def _stack(poly: bool) -> EKFStack:
    filters = [FilterConfig(name="a"), FilterConfig(name="b"), FilterConfig(name="c")]
    if poly:
        filters[1] = FilterConfig(name="b", accel=PolyAccelConfig(sigma_km_s2=1e-12, degree=1))
    return EKFStack(BankConfig(filters=tuple(filters)), *entry_state(), ENV)


@pytest.mark.parametrize("poly", [False, True])
@pytest.mark.parametrize("days_before_entry, span_s", [(30.0, 60.0), (20.0, 3600.0), (5.0, -60.0), (0.3, 900.0)])
def test_kernel_matches_numpy_reference(poly, days_before_entry, span_s):
    rng = np.random.default_rng(int(days_before_entry * 10) + (7 if poly else 0))
    st = _stack(poly)
    t_e = st.t
    t0 = t_e - days_before_entry * 86400.0
    q0 = st.drivers()
    r0, v0, _ = st.propagator.propagate(t_e, t0, st.x[:, 0:3], st.x[:, 3:6], q0, with_stm=False)
    N = r0.shape[0]
    r0 = r0 + rng.normal(0.0, 50.0, (N, 3))
    v0 = v0 + rng.normal(0.0, 1e-3, (N, 3))
    q = rng.normal(0.0, 0.05, q0.shape)
    if poly:
        q[:, 4:] = rng.normal(0.0, 1e-11, (N, q.shape[1] - 4))
    ref = ReferencePropagator(ENV, st.forces, st.config.step_fraction, st.config.max_step_s)
    for tol in (1e-10, 0.0):  # the frozen-gradient step and the stage-by-stage integration
        ref.frozen_gradient_tol = tol
        st.propagator.frozen_gradient_tol = tol
        r1, v1, Y = st.propagator.propagate(t0, t0 + span_s, r0, v0, q)
        r1r, v1r, Yr = ref.propagate(t0, t0 + span_s, r0, v0, q)
        assert np.max(np.abs(r1 - r1r) / np.abs(r1r).max()) < 1e-14
        assert np.max(np.abs(v1 - v1r) / np.abs(v1r).max()) < 1e-13
        # every column of Y relative to its own scale (position/velocity/driver columns differ by 1e10)
        scale = np.abs(Yr).max(axis=(1,), keepdims=True) + 1e-300
        assert np.max(np.abs(Y - Yr) / scale) < 1e-12
        r1n, v1n, none = st.propagator.propagate(t0, t0 + span_s, r0, v0, q, with_stm=False)
        assert none is None and np.array_equal(r1n, r1) and np.array_equal(v1n, v1)


def _reference_covariance_transition(st: EKFStack, P: np.ndarray, Y: np.ndarray, h: float) -> np.ndarray:
    """Dense Φ P Φᵀ + Q, symmetrised, in numpy (the stack's former arithmetic)."""
    from fsw.models.clock import clock_process_noise, clock_transition

    N, n, _ = P.shape
    Phi = np.zeros((N, n, n))
    Phi[:, np.arange(6, n), np.arange(6, n)] = 1.0
    Phi[:, 0:6, :] = Y @ st.z_to_state
    if st.clock_columns is not None:
        c0, c1 = st.clock_columns
        Phi[:, c0:c1, c0:c1] = clock_transition(h, c1 - c0)
    out = Phi @ P @ Phi.transpose(0, 2, 1)
    if st.clock_columns is not None:
        out[:, c0:c1, c0:c1] += clock_process_noise(abs(h), st.clock_q)[:, : c1 - c0, : c1 - c0]
    q = st.snc_psd[:, None, None]
    out[:, 0:3, 0:3] += (q * abs(h) ** 3 / 3.0) * np.eye(3)
    out[:, 0:3, 3:6] += (q * h**2 / 2.0) * np.eye(3)
    out[:, 3:6, 0:3] += (q * h**2 / 2.0) * np.eye(3)
    out[:, 3:6, 3:6] += (q * abs(h)) * np.eye(3)
    return 0.5 * (out + out.transpose(0, 2, 1))


@pytest.mark.parametrize("seed", range(4))
def test_time_update_kernel_matches_dense_products(seed):
    from fsw.kernels.time_update import time_update

    rng = np.random.default_rng(seed)
    st = _stack(poly=bool(seed % 2))
    st.snc_psd[:] = rng.uniform(0.0, 1e-12, st.snc_psd.shape) * (seed > 1)
    N, n = st.x.shape
    A = rng.normal(size=(N, n, n)) * np.sqrt(np.diag(st.P[0]) + 1e-30)[None, :, None]
    P = A @ A.transpose(0, 2, 1)
    Y = rng.normal(size=(N, 6, 6 + st.layout.n_q))
    h = float(rng.uniform(10.0, 600.0))
    out = np.empty_like(P)
    c0, c1 = st.clock_columns or (0, 0)
    x = rng.normal(size=(N, n)) * np.sqrt(np.diag(st.P[0]))
    z1 = rng.normal(size=(N, 6))
    x_out = np.empty_like(x)
    time_update(x, z1, P, Y, st.state_sources, c0, c1, h, st.clock_q, st.snc_psd, x_out, out)
    ref = _reference_covariance_transition(st, P, Y, h)
    x_ref = x.copy()
    x_ref[:, 0:6] = z1
    if st.clock_columns is not None:
        from fsw.models.clock import clock_transition

        x_ref[:, c0:c1] = x[:, c0:c1] @ clock_transition(h, c1 - c0).T
    assert np.allclose(x_out, x_ref, rtol=1e-15, atol=0.0)
    d = np.sqrt(np.abs(np.einsum("kii->ki", ref)))
    assert np.max(np.abs(out - ref) / (d[:, :, None] * d[:, None, :] + 1e-300)) < 1e-13
    assert np.array_equal(out, out.transpose(0, 2, 1))

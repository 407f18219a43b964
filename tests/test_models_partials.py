"""Every analytic partial of the onboard models against central finite differences.

Error measure: for a row of H, max_j |H_ij − H_fd,ij| σ_j / max_j |H_ij σ_j| with σ_j the
a-priori 1-sigma of state j — the error in the predicted measurement for a one-sigma change of
each state, relative to the largest such change. Dominant entries are also checked one by one.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fsw.filters.config import BankConfig, FilterConfig, PolyAccelConfig
from fsw.filters.ekf import EKFStack
from fsw.filters.optical_kind import predict_optical
from fsw.filters.radiometric_kinds import predict_doppler, predict_range
from fsw.models.environment import Environment
from fsw.models.forces import acceleration
from tools.bench.synthetic import _camera_to_icrf, entry_state

ENV = Environment()


def _stack(hours_before_entry: float, **cfg) -> EKFStack:
    f = FilterConfig(name="f", accel=PolyAccelConfig(sigma_km_s2=5e-12, degree=1), **cfg)
    t_e, r_e, v_e = entry_state()
    probe = EKFStack(BankConfig(filters=(f,)), t_e, r_e, v_e, ENV)
    t0 = t_e - hours_before_entry * 3600.0
    r0, v0, _ = probe.propagator.propagate(t_e, t0, r_e[None], v_e[None], probe.drivers(), with_stm=False)
    st = EKFStack(BankConfig(filters=(f,)), t0, r0[0], v0[0], ENV)
    L = st.layout
    # a state off zero in every parameter, so no partial is tested at a trivial point
    st.x[0, L.slices["srp_bias"]] = 0.08
    st.x[0, L.slices["srp_stoch"]] = -0.02
    st.x[0, L.slices["acs_bias"]] = 0.5
    st.x[0, L.slices["acs_stoch"]] = 0.3
    st.x[0, L.slices["acs_tilt"]] = (0.04, -0.03)
    st.x[0, L.slices["accel"]] = np.linspace(-4e-12, 6e-12, L.slices["accel"].stop - L.slices["accel"].start)
    c = L.slices["clock"].start
    st.x[0, c : c + 3] = (2e-6, 3e-13, 4e-21)
    st.x[0, L.slices["range_bias"]] = 0.004
    return st


def _steps(st: EKFStack, pos: float, vel: float = 1e-2, srp: float = 0.1, acs: float = 1.0, accel: float = 1e-10,
           phase: float = 1e-6, tilt: float = 0.05) -> np.ndarray:
    """Central-difference steps: large enough to rise above the rounding of the measurement
    (a range of 2e8 km carries 3e-8 km of it), small enough for truncation; the model is
    close to linear in the force parameters, so those steps can be large."""
    L = st.layout
    h = np.empty(L.n)
    h[0:3] = pos
    h[3:6] = vel
    h[L.slices["srp_bias"]] = h[L.slices["srp_stoch"]] = srp
    h[L.slices["acs_bias"]] = h[L.slices["acs_stoch"]] = acs
    h[L.slices["acs_tilt"]] = tilt
    h[L.slices["accel"]] = accel
    c = L.slices["clock"].start
    h[c : c + 3] = (phase, 1e-10, 1e-15)
    h[L.slices["range_bias"]] = 1.0
    return h


def _fd(fun, x: np.ndarray, steps: np.ndarray) -> np.ndarray:
    cols = []
    for j, e in enumerate(steps):
        xp, xm = x.copy(), x.copy()
        xp[0, j] += e
        xm[0, j] -= e
        cols.append((fun(xp) - fun(xm)) / (2 * e))
    return np.stack(cols, axis=-1)  # (1, m, n)


def _check(H: np.ndarray, H_fd: np.ndarray, sigma: np.ndarray, tol: float = 1e-6) -> None:
    for row, row_fd in zip(H[0], H_fd[0]):
        ref = np.max(np.abs(row * sigma))
        err = np.max(np.abs((row - row_fd) * sigma)) / ref
        assert err < tol, (err, row, row_fd)
        big = np.abs(row * sigma) > 1e-3 * ref
        rel = np.abs(row[big] - row_fd[big]) / np.abs(row[big])
        assert np.all(rel < 1e-5), (rel, row[big], row_fd[big])


def _sigma(st: EKFStack) -> np.ndarray:
    return np.sqrt(np.diag(st.P[0]))


@pytest.mark.parametrize("station", ["DSS-14", "DSS-43", "DSS-63"])
def test_range_partials(station):
    st = _stack(48.0)
    t = st.t
    h, H = predict_range(st, station, t, st.x)
    H_fd = _fd(lambda x: predict_range(st, station, t, x)[0], st.x, _steps(st, 1e3))
    _check(H, H_fd, _sigma(st))


def test_range_includes_clock_phase_as_c_delta():
    # independent hand check: 1 µs of clock phase is ~c·1e-6 km of range
    st = _stack(30.0)
    c = st.layout.slices["clock"].start
    h0 = predict_range(st, "DSS-14", st.t, st.x)[0][0, 0]
    x = st.x.copy()
    x[0, c] += 1e-6
    h1 = predict_range(st, "DSS-14", st.t, x)[0][0, 0]
    assert h1 - h0 == pytest.approx(0.299792458, rel=1e-3)


@pytest.mark.parametrize("hours", [200.0, 12.0])
def test_doppler_partials(hours):
    st = _stack(hours)
    t = st.t
    h, H = predict_doppler(st, "DSS-43", t, 60.0, st.x)
    steps = _steps(st, 1e4 if hours > 100 else 1e3, srp=10.0, acs=100.0, accel=1e-5, phase=1e-3, tilt=100.0)
    H_fd = _fd(lambda x: predict_doppler(st, "DSS-43", t, 60.0, x)[0], st.x, steps)
    _check(H, H_fd, _sigma(st))


def test_doppler_is_the_range_rate_plus_c_times_frequency():
    # independent check: differenced range of the range model over the count interval
    st = _stack(100.0)
    t, T = st.t, 60.0
    d = predict_doppler(st, "DSS-63", t, T, st.x)[0][0, 0]
    back = EKFStack(st.config, t, st.x[0, 0:3], st.x[0, 3:6], ENV)
    back.x[:] = st.x
    r_s, v_s, _ = st.propagator.propagate(t, t - T, st.x[:, 0:3], st.x[:, 3:6], st.drivers())
    x_s = st.x.copy()
    x_s[:, 0:3], x_s[:, 3:6] = r_s, v_s
    c = st.layout.slices["clock"].start
    phase, freq, drift = st.x[0, c : c + 3]
    x_s[0, c] = phase - freq * T + 0.5 * drift * T * T  # the clock phase at the start of the count
    r_end = predict_range(st, "DSS-63", t, st.x)[0][0, 0]
    r_start = predict_range(st, "DSS-63", t - T, x_s)[0][0, 0]
    # the range model puts the start reception at t − T − δ_start, the Doppler model at
    # t − T − δ_end: a shift of (δ_end − δ_start) ~ 2e-11 s, i.e. ~1e-10 km/s here
    assert d == pytest.approx((r_end - r_start) / T, abs=1e-9)


@pytest.mark.parametrize("target", ["mars", "phobos", "deimos", "vesta", "hygiea"])
@pytest.mark.parametrize("aberration", [False, True])
def test_optical_partials(target, aberration):
    st = _stack(20.0, camera=dataclasses.replace(FilterConfig(name="c").camera, aberration=aberration))
    t = st.t
    r_t, _ = ENV.target_state(target, t)
    q = __import__("fsw.astro.frames", fromlist=["matrix_to_quat"]).matrix_to_quat(
        _camera_to_icrf(r_t - st.x[0, 0:3] + np.array([30.0, -20.0, 10.0]))
    )
    h, H = predict_optical(st, target, t, q, st.x)
    H_fd = _fd(lambda x: predict_optical(st, target, t, q, x)[0], st.x, _steps(st, 10.0))
    _check(H, H_fd, _sigma(st))
    assert np.all(np.abs(h - 512.5) < 512)  # target in the image


def test_acceleration_partials_against_finite_differences():
    st = _stack(10.0)
    r = st.x[:, 0:3]
    q = st.drivers()
    bodies = ENV.third_bodies(st.t)
    s = np.array([0.3])
    a, G, dadq = acceleration(r, q, bodies, s, st.forces)
    for j in range(3):
        e = np.zeros((1, 3))
        e[0, j] = 1.0
        fd = (acceleration(r + e, q, bodies, s, st.forces)[0] - acceleration(r - e, q, bodies, s, st.forces)[0]) / 2.0
        np.testing.assert_allclose(G[0, :, j], fd[0], rtol=1e-6, atol=1e-9 * np.abs(G).max())
    for j in range(q.shape[1]):
        dq = np.zeros_like(q)
        dq[0, j] = 1e-3 if j < 4 else 1e-11
        fd = (acceleration(r, q + dq, bodies, s, st.forces)[0] - acceleration(r, q - dq, bodies, s, st.forces)[0]) / (2 * dq[0, j])
        np.testing.assert_allclose(dadq[0, :, j], fd[0], rtol=1e-6, atol=1e-12 * np.abs(dadq[0, :, j]).max() + 1e-30)


def test_state_transition_matrix_against_finite_differences():
    st = _stack(8.0)
    t0, t1 = st.t, st.t + 3600.0
    r, v, q = st.x[:, 0:3], st.x[:, 3:6], st.drivers()
    _, _, Y = st.propagator.propagate(t0, t1, r, v, q)
    z = np.concatenate([r, v, q], axis=1)
    steps = np.concatenate([np.full(3, 1e-2), np.full(3, 1e-5), [1e-2, 1e-2, 1e-2, 1e-2], np.full(q.shape[1] - 4, 1e-11)])

    def final(zz):
        r1, v1, _ = st.propagator.propagate(t0, t1, zz[:, 0:3], zz[:, 3:6], zz[:, 6:], with_stm=False)
        return np.concatenate([r1, v1], axis=1)[:, :, None][:, :, 0]

    fd = _fd(final, z, steps)  # (1, 6, 6 + nq)
    scale = np.concatenate([np.full(3, 100.0), np.full(3, 1e-4), [0.1, 0.1, 0.05, 0.05], np.full(q.shape[1] - 4, 5e-12)])
    for i in range(6):
        ref = np.max(np.abs(Y[0, i] * scale))
        assert np.max(np.abs((Y[0, i] - fd[0, i]) * scale)) / ref < 1e-6

"""The onboard clock: Allan deviation of a long realisation, exact discretisation, interpolation."""

import numpy as np
import pytest
from scipy.linalg import expm

from sim.clock import ClockConfig, ClockError, ClockStep, ClockTruth, process_noise, simulate_clock, transition

DAY = 86400.0


def overlapping_adev(phase: np.ndarray, tau0: float, m: int) -> float:
    """Overlapping Allan deviation from phase samples x_i (IEEE 1139 / NIST SP 1065 eq. 12)."""
    x = np.asarray(phase)
    d = x[2 * m:] - 2.0 * x[m:-m] + x[: -2 * m]
    tau = m * tau0
    return float(np.sqrt(np.sum(d * d) / (2.0 * tau * tau * d.size)))


def test_default_clock_has_dsac_allan_deviation():
    # 2000 days sampled hourly, deterministic drift removed (ADEV is quoted drift-free):
    # DESIGN.md asks for ~2e-15 at one day.
    cfg = ClockConfig(drift_per_day=0.0, drift_sigma_per_day=0.0, node_step_s=3600.0)
    clk = simulate_clock(cfg, 0.0, 2000 * DAY, np.random.default_rng(7))
    phase = clk.nodes[:, 0]
    adev_day = overlapping_adev(phase, 3600.0, 24)
    assert adev_day == pytest.approx(2.0e-15, rel=0.08)
    # Slope check against the model terms written out here: q1/tau + q2 tau/3 at 1 h and 10 d.
    q1, q2 = cfg.q_white_fm_s, cfg.q_random_walk_fm_per_s
    for m, tol in ((1, 0.03), (240, 0.25)):
        tau = m * 3600.0
        expected = np.sqrt(q1 / tau + q2 * tau / 3.0)
        assert overlapping_adev(phase, 3600.0, m) == pytest.approx(expected, rel=tol)


def test_drift_is_realised():
    # Without noise the frequency ramps by exactly drift x T and the phase by drift T^2 / 2.
    cfg = ClockConfig(drift_sigma_per_day=0.0, q_white_fm_s=0.0, q_random_walk_fm_per_s=0.0,
                      q_random_run_per_s3=0.0, phase0_sigma_s=0.0, frequency0_sigma=0.0)
    clk = simulate_clock(cfg, 0.0, 45 * DAY, np.random.default_rng(1))
    assert np.allclose(clk.nodes[:, 2], 3.0e-16 / DAY, rtol=0, atol=1e-30)
    f = clk.nodes[:, 1]
    assert (f[-1] - f[0]) == pytest.approx(3.0e-16 * 45, rel=1e-9)
    b = clk.phase(30 * DAY + 17.0)
    assert b == pytest.approx(0.5 * 3.0e-16 / DAY * (30 * DAY + 17.0) ** 2, rel=1e-9)


def test_process_noise_matches_van_loan():
    # Independent: Van Loan's matrix exponential gives Phi and Q_d of the continuous model.
    q = np.array([2.2e-25, 5e-35, 1e-50])
    F = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    for h in (1.0, 60.0, 3600.0, 86400.0):
        # Scale states to keep the exponential well conditioned: z = D^-1 x.
        D = np.diag([1e-12, 1e-17, 1e-22])
        Di = np.linalg.inv(D)
        Fs, Qs = Di @ F @ D, Di @ np.diag(q) @ Di
        A = np.block([[-Fs, Qs], [np.zeros((3, 3)), Fs.T]]) * h
        E = expm(A)
        phi_s = E[3:, 3:].T
        Qd_s = phi_s @ E[:3, 3:]
        Qd = D @ Qd_s @ D
        np.testing.assert_allclose(D @ phi_s @ Di, transition(h), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(process_noise(h, *q), Qd, rtol=1e-9, atol=0)


def test_sampled_increments_have_the_exact_covariance():
    cfg = ClockConfig(phase0_sigma_s=0.0, frequency0_sigma=0.0, drift_per_day=0.0, drift_sigma_per_day=0.0,
                      q_random_run_per_s3=1e-44, node_step_s=600.0)
    clk = simulate_clock(cfg, 0.0, 20000 * 600.0, np.random.default_rng(3))
    x = clk.nodes
    w = x[1:] - x[:-1] @ transition(600.0).T
    Q = process_noise(600.0, cfg.q_white_fm_s, cfg.q_random_walk_fm_per_s, cfg.q_random_run_per_s3)
    d = np.sqrt(np.diag(Q))
    emp = np.cov(w.T) / np.outer(d, d)
    np.testing.assert_allclose(emp, Q / np.outer(d, d), atol=0.03)


def test_interpolation_is_consistent_and_hits_the_nodes():
    clk = simulate_clock(ClockConfig(), 1000.0, 1000.0 + 2 * DAY, np.random.default_rng(5))
    b, f, a = clk.state(clk.t_nodes[10:20])
    np.testing.assert_allclose(b, clk.nodes[10:20, 0], rtol=0, atol=1e-22)
    np.testing.assert_allclose(f, clk.nodes[10:20, 1], rtol=0, atol=1e-27)
    np.testing.assert_allclose(a, clk.nodes[10:20, 2], rtol=0, atol=1e-32)
    # Frequency is the rate of the interpolated phase (central difference inside a node step).
    t = 1000.0 + 3600.0 + np.array([7.0, 23.5, 41.0])
    h = 0.01
    rate = (clk.phase(t + h) - clk.phase(t - h)) / (2 * h)
    np.testing.assert_allclose(rate, clk.state(t)[1], rtol=0, atol=1e-17)
    with pytest.raises(ClockError):
        clk.state(clk.t_end + 1.0)
    with pytest.raises(ClockError):
        clk.state(np.nan)


def test_steps_shift_phase_and_frequency_only_inside_their_window():
    clk = simulate_clock(ClockConfig(), 0.0, 3 * DAY, np.random.default_rng(2))
    stepped = clk.with_steps((ClockStep(t_on=DAY, t_off=2 * DAY, phase_s=1e-6, frequency=1e-12),))
    t = np.array([0.5 * DAY, DAY + 100.0, 2 * DAY + 5.0])
    b0, f0, _ = clk.state(t)
    b1, f1, _ = stepped.state(t)
    np.testing.assert_allclose(b1 - b0, [0.0, 1e-6 + 1e-12 * 100.0, 0.0], atol=1e-20)
    np.testing.assert_allclose(f1 - f0, [0.0, 1e-12, 0.0], atol=1e-25)
    assert stepped.reading(DAY + 100.0) - clk.reading(DAY + 100.0) == pytest.approx(1e-6 + 1e-10, abs=1e-9)


def test_bad_nodes_are_rejected():
    with pytest.raises(ClockError):
        ClockTruth(np.array([0.0, 1.0, 3.0]), np.zeros((3, 3)))
    with pytest.raises(ClockError):
        ClockTruth(np.array([0.0, 1.0]), np.array([[0.0, np.nan, 0.0], [0.0, 0.0, 0.0]]))

"""A linear actuator-failure case for residual-correlation hypothesis testing (Hanlon & Maybeck 2000).

A small spacecraft attitude model: two axes, each a double integrator (angle, rate) sampled at
100 Hz, driven by three actuators (thrusters or wheels) whose torque directions are the columns of
``B``. Every actuator carries a small known sinusoidal excitation (dither) at its own frequency, so
that its loss leaves a sinusoid at that frequency in the residuals of every filter that still
models it. Angles and rates are measured with white noise; rates take white process noise.

Hypotheses: filter 0 models every actuator; filter j (1..3) models actuator j as failed (its
column of B zero). The truth flies nominally until ``fail_at`` and then with one actuator failed.
The dither is generated inside each filter by a known, noise-free oscillator (two states per
actuator, exact initial phase), so the linear bank needs no control input.

numpy only: the truth and the matrices of the bank; no filter code.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

DT = 0.01  # s: 100 Hz, as Hanlon & Maybeck's aircraft simulation
#: torque direction of each actuator in the two-axis plane [rad/s² per unit command]
B = np.array([[1.0, 0.0, -0.7071], [0.0, 1.0, -0.7071]])
#: dither frequency of each actuator [cycles per sample] and its nominal amplitude [rad/s²]
FREQUENCIES = (0.05, 0.08, 0.11)
AMPLITUDE = 0.2
RATE_NOISE = 1e-3  # rad/s per step, 1σ process noise on each rate
ANGLE_SIGMA = 2e-3  # rad, angle measurement noise
RATE_SIGMA = 1e-3  # rad/s, rate measurement noise
N_ACT = B.shape[1]
N_STATE = 4 + 2 * N_ACT  # [θ1 θ2 ω1 ω2] + an oscillator (cos, sin) per actuator
HYPOTHESES = ("nominal", "act1-failed", "act2-failed", "act3-failed")


class DitherRun(NamedTuple):
    z: np.ndarray  # (K, 4): measured θ1 θ2 ω1 ω2
    x: np.ndarray  # (K, 4): true θ1 θ2 ω1 ω2
    fail_at: int
    failed: int  # actuator index 1..3 (0: none)


def transition(failed: int, amplitude: float) -> np.ndarray:
    """F of the hypothesis 'actuator ``failed`` (1..3; 0 = none) is lost', dither of ``amplitude``."""
    F = np.eye(N_STATE)
    F[0:2, 2:4] = DT * np.eye(2)
    for j in range(N_ACT):
        w = 2.0 * np.pi * FREQUENCIES[j]
        o = 4 + 2 * j
        F[o:o + 2, o:o + 2] = [[np.cos(w), -np.sin(w)], [np.sin(w), np.cos(w)]]
        if j + 1 != failed:
            # torque = amplitude · sin-component of the oscillator, through column j of B
            F[0:2, o + 1] = 0.5 * DT * DT * amplitude * B[:, j]
            F[2:4, o + 1] = DT * amplitude * B[:, j]
    return F


def bank_matrices(amplitude: float) -> dict[str, np.ndarray]:
    """F, Q, H, R, x0, P0 of the four-hypothesis bank."""
    F = np.stack([transition(h, amplitude) for h in range(len(HYPOTHESES))])
    Q = np.zeros((N_STATE, N_STATE))
    Q[2, 2] = Q[3, 3] = RATE_NOISE ** 2
    H = np.zeros((4, N_STATE))
    H[:, :4] = np.eye(4)
    R = np.diag([ANGLE_SIGMA ** 2] * 2 + [RATE_SIGMA ** 2] * 2)
    x0 = np.zeros(N_STATE)
    x0[4::2] = 1.0  # oscillators start at phase 0: (cos, sin) = (1, 0)
    P0 = np.zeros((N_STATE, N_STATE))
    P0[:4, :4] = np.diag([ANGLE_SIGMA ** 2] * 2 + [RATE_SIGMA ** 2] * 2)
    return {"F": F, "Q": Q, "H": H, "R": R, "x0": x0, "P0": P0}


def generate(rng: np.random.Generator, amplitude: float, failed: int, fail_at: int, length: int) -> DitherRun:
    """Truth and measurements: nominal for k < fail_at, then actuator ``failed`` lost."""
    Fn, Ff = transition(0, amplitude), transition(failed, amplitude)
    s = np.zeros(N_STATE)
    s[4::2] = 1.0
    xs, zs = [], []
    for k in range(length):
        if k > 0:
            s = (Fn if k <= fail_at else Ff) @ s
            s[2:4] += rng.normal(0.0, RATE_NOISE, 2)
        xs.append(s[:4].copy())
        zs.append(s[:4] + rng.normal(0.0, 1.0, 4) * [ANGLE_SIGMA, ANGLE_SIGMA, RATE_SIGMA, RATE_SIGMA])
    return DitherRun(np.array(zs), np.array(xs), fail_at, failed)

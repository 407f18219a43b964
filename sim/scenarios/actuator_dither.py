"""A linear actuator-failure case for residual-correlation hypothesis testing (Hanlon & Maybeck 2000).

A small two-axis attitude model sampled at 100 Hz (Hanlon & Maybeck's aircraft simulation rate),
driven by three actuators (thrusters or wheels) whose torque directions are the columns of ``B``,
each dithered at its own frequency. The model, the hypotheses and the generator are those of
:mod:`sim.scenarios.dither_case`; this module fixes the numbers. The spacecraft case
(:mod:`sim.scenarios.wheel_dither`) is the same construction in three axes with four wheels.
"""

from __future__ import annotations

import numpy as np

from sim.scenarios.dither_case import DitherCase, DitherRun

DT = 0.01  # s: 100 Hz, as Hanlon & Maybeck's aircraft simulation
#: torque direction of each actuator in the two-axis plane [rad/s² per unit command]
B = np.array([[1.0, 0.0, -0.7071], [0.0, 1.0, -0.7071]])
#: dither frequency of each actuator [cycles per sample] and its nominal amplitude [rad/s²]
FREQUENCIES = (0.05, 0.08, 0.11)
AMPLITUDE = 0.2
RATE_NOISE = 1e-3  # rad/s per step, 1σ process noise on each rate
ANGLE_SIGMA = 2e-3  # rad, angle measurement noise
RATE_SIGMA = 1e-3  # rad/s, rate measurement noise

CASE = DitherCase("two-axis, three actuators", DT, B, FREQUENCIES, AMPLITUDE, RATE_NOISE, ANGLE_SIGMA, RATE_SIGMA)
N_ACT = CASE.n_act
N_STATE = CASE.n_state  # [θ1 θ2 ω1 ω2] + an oscillator (cos, sin) per actuator
HYPOTHESES = CASE.hypotheses  # nominal, act1-failed, act2-failed, act3-failed

__all__ = ["CASE", "DitherRun", "transition", "bank_matrices", "generate"]


def transition(failed: int, amplitude: float) -> np.ndarray:
    """F of the hypothesis 'actuator ``failed`` (1..3; 0 = none) is lost', dither of ``amplitude``."""
    return CASE.transition(failed, amplitude)


def bank_matrices(amplitude: float) -> dict[str, np.ndarray]:
    """F, Q, H, R, x0, P0 of the four-hypothesis bank."""
    return CASE.bank_matrices(amplitude)


def generate(rng: np.random.Generator, amplitude: float, failed: int, fail_at: int, length: int) -> DitherRun:
    """Truth and measurements: nominal for k ≤ fail_at, then actuator ``failed`` lost."""
    return CASE.generate(rng, amplitude, failed, fail_at, length)

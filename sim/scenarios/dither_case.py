"""Linear actuator-failure cases with a known sinusoidal dither (Hanlon & Maybeck 2000), in general.

An attitude model of ``axes`` small angles θ and rates ω (each axis a double integrator, valid for
the small angles and rates of a spacecraft holding attitude) sampled every ``dt`` and driven by
``B.shape[1]`` actuators whose angular acceleration per unit command are the columns of ``B``.
Every actuator carries a known sinusoidal dither at its own frequency (cycles per sample), so its
loss leaves a sinusoid at that frequency in the residuals of every filter that still models it.
Angles and rates are measured with white noise; rates take white process noise (unmodelled
disturbance torques).

Hypotheses: filter 0 models every actuator; filter j (1..n_act) models actuator j as failed (its
column of B zero). The truth flies nominally until ``fail_at`` and then with one actuator failed
(``failed = 0``: nominal throughout). The dither is generated inside each filter by a known,
noise-free oscillator (two states per actuator, exact initial phase), so the linear bank needs no
control input and the filters differ only in their input columns.

numpy only: the truth and the matrices of the bank; no filter code.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


class DitherRun(NamedTuple):
    z: np.ndarray  # (K, 2·axes): measured angles then rates
    x: np.ndarray  # (K, 2·axes): true angles then rates
    fail_at: int
    failed: int  # actuator index 1..n_act (0: none)


@dataclass(frozen=True)
class DitherCase:
    """One linear actuator-failure case: geometry, dither, noise and sampling."""

    name: str
    dt: float  # s per sample
    B: np.ndarray  # (axes, n_act): angular acceleration per unit command [rad/s²]
    frequencies: tuple[float, ...]  # dither frequency of each actuator [cycles per sample]
    amplitude: float  # nominal dither command amplitude (multiplier 1.0)
    rate_noise: float  # rad/s per step, 1σ process noise on each rate
    angle_sigma: float  # rad, angle measurement noise 1σ
    rate_sigma: float  # rad/s, rate measurement noise 1σ
    actuator: str = "act"  # how hypotheses name an actuator

    @property
    def axes(self) -> int:
        return int(self.B.shape[0])

    @property
    def n_act(self) -> int:
        return int(self.B.shape[1])

    @property
    def n_state(self) -> int:
        return 2 * self.axes + 2 * self.n_act  # [θ ω] + an oscillator (cos, sin) per actuator

    @property
    def hypotheses(self) -> tuple[str, ...]:
        return ("nominal",) + tuple(f"{self.actuator}{j + 1}-failed" for j in range(self.n_act))

    def transition(self, failed: int, amplitude: float) -> np.ndarray:
        """F of the hypothesis 'actuator ``failed`` (1..n_act; 0 = none) is lost', dither of ``amplitude``."""
        a, dt = self.axes, self.dt
        F = np.eye(self.n_state)
        F[0:a, a:2 * a] = dt * np.eye(a)
        for j in range(self.n_act):
            w = 2.0 * np.pi * self.frequencies[j]
            o = 2 * a + 2 * j
            F[o:o + 2, o:o + 2] = [[np.cos(w), -np.sin(w)], [np.sin(w), np.cos(w)]]
            if j + 1 != failed:
                # command = amplitude · sin-component of the oscillator, through column j of B
                F[0:a, o + 1] = 0.5 * dt * dt * amplitude * self.B[:, j]
                F[a:2 * a, o + 1] = dt * amplitude * self.B[:, j]
        return F

    def bank_matrices(self, amplitude: float) -> dict[str, np.ndarray]:
        """F, Q, H, R, x0, P0 of the bank (one filter per hypothesis)."""
        a, n = self.axes, self.n_state
        F = np.stack([self.transition(h, amplitude) for h in range(len(self.hypotheses))])
        Q = np.zeros((n, n))
        Q[a:2 * a, a:2 * a] = self.rate_noise ** 2 * np.eye(a)
        H = np.zeros((2 * a, n))
        H[:, :2 * a] = np.eye(2 * a)
        sig = np.array([self.angle_sigma] * a + [self.rate_sigma] * a)
        x0 = np.zeros(n)
        x0[2 * a::2] = 1.0  # oscillators start at phase 0: (cos, sin) = (1, 0)
        P0 = np.zeros((n, n))
        P0[:2 * a, :2 * a] = np.diag(sig ** 2)
        return {"F": F, "Q": Q, "H": H, "R": np.diag(sig ** 2), "x0": x0, "P0": P0}

    def generate(self, rng: np.random.Generator, amplitude: float, failed: int, fail_at: int,
                 length: int) -> DitherRun:
        """Truth and measurements: nominal for k ≤ fail_at, then actuator ``failed`` lost."""
        a = self.axes
        Fn, Ff = self.transition(0, amplitude), self.transition(failed, amplitude)
        sig = np.array([self.angle_sigma] * a + [self.rate_sigma] * a)
        s = np.zeros(self.n_state)
        s[2 * a::2] = 1.0
        xs, zs = [], []
        for k in range(length):
            if k > 0:
                s = (Fn if k <= fail_at else Ff) @ s
                s[a:2 * a] += rng.normal(0.0, self.rate_noise, a)
            xs.append(s[:2 * a].copy())
            zs.append(s[:2 * a] + rng.normal(0.0, 1.0, 2 * a) * sig)
        return DitherRun(np.array(zs), np.array(xs), fail_at, failed)

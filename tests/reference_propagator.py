"""The numpy propagator the compiled kernel replaced (fsw.kernels.variational_rk4), kept as the
independent reference the kernel tests compare against.

Trajectory and state-transition-matrix propagation for a stack of N filters at once.

The position/velocity z = [r, v] obeys ż = [v, a(r, q, t)] (forces in :mod:`fsw.models.forces`);
the acceleration drivers q are constant over a propagation interval (the filter splits its
propagation at batch boundaries). The sensitivity Y = ∂z(t)/∂[z(t0), q] (N, 6, 6 + n_q)
integrates with the state (variational equations):

    Ẏ_r = Y_v,    Ẏ_v = G Y_r + [0 | ∂a/∂q].

Classical fourth-order Runge–Kutta with a step of κ·min(√(r³/μ), r/|v|) — a fixed fraction of
the local dynamical time, so steps shrink automatically towards Mars — capped at ``max_step``.
Y integrated with the same stages is the exact derivative of the discrete RK map, so the
filter's STM is consistent with its trajectory to rounding.

Cost is per-call overhead on tiny arrays, so the work is arranged to need few numpy calls:
z and Y ride in one array S = [z | Y] (N, 6, 1 + 6 + n_q), so each RK stage is one
expression for both; the per-epoch quantities (third-body positions, the four 1/d² centres,
the indirect acceleration) are cached by epoch, so the end of one interval serves as the start
of the next; the direction of the small ACS force (a cruise frame turning by < 1e-5 rad per
step) is evaluated once per step.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import Literal, overload

import numpy as np

from fsw.astro.constants import GM_MARS
from fsw.models.environment import Environment
from fsw.models.forces import (
    ForceParameters,
    acs_terms,
    centres,
    point_mass_coefficients,
    point_mass_gradient,
    point_masses,
    poly_powers,
)
from fsw.models.layout import N_Q_FIXED


_FREE_FLIGHT: dict[float, np.ndarray] = {}


def _identity_with(h: float) -> np.ndarray:
    """[[I, h I], [0, I]]: the part of the step's Φ that does not involve G (cached: steps
    take few distinct lengths)."""
    out = _FREE_FLIGHT.get(h)
    if out is None:
        out = np.eye(6)
        out[0:3, 3:6] = h * np.eye(3)
        if len(_FREE_FLIGHT) < 4096:
            _FREE_FLIGHT[h] = out
    return out


class ReferencePropagator:
    """RK4 propagation of N trajectories and their sensitivities."""

    _EPOCH_CACHE = 8
    #: Bound on the relative STM change from freezing G over a step (see :meth:`propagate`);
    #: 0 integrates the variational equations stage by stage everywhere.
    frozen_gradient_tol = 1e-10

    def __init__(self, env: Environment, params: ForceParameters, step_fraction: float = 0.02, max_step_s: float = 600.0):
        if not 0.0 < step_fraction <= 0.2 or max_step_s <= 0.0:
            raise ValueError("step_fraction must be in (0, 0.2] and max_step_s > 0")
        self.env = env
        self.params = params
        self.kappa = step_fraction
        self.max_step = max_step_s
        self._epochs: OrderedDict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = OrderedDict()
        deg = params.poly_degree
        if deg is not None:
            k = np.repeat(np.arange(deg + 1), 3)
            self._poly_rows = np.tile(np.arange(3), deg + 1)
            self._poly_cols = N_Q_FIXED + np.arange(3 * (deg + 1))
            self._poly_k = k

    def step_size(self, r: np.ndarray, v: np.ndarray) -> float:
        # min over filters of min(√(r³/μ), r/|v|) = √(r² min(r/μ, 1/v²))
        scale = min(r2 * min(math.sqrt(r2) / GM_MARS, 1.0 / max(v2, 1e-18))
                    for r2, v2 in zip(np.vecdot(r, r).tolist(), np.vecdot(v, v).tolist()))
        return min(self.max_step, self.kappa * math.sqrt(scale))

    def _batch_start(self, t: float) -> np.ndarray:
        T = self.params.poly_batch_s
        o = self.params.poly_origin_s
        return o + np.floor((t - o) / T) * T

    def epoch(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(third bodies (3, 3), 1/d² centres (4, 3), indirect acceleration (3,)) at t, cached."""
        hit = self._epochs.get(t)
        if hit is None:
            bodies = self.env.third_bodies(t)
            b, indirect = centres(bodies)
            hit = (bodies, b, indirect)
            self._epochs[t] = hit
            if len(self._epochs) > self._EPOCH_CACHE:
                self._epochs.popitem(last=False)
        return hit

    def _forcing(self, d: np.ndarray, d2: np.ndarray, acs_part: np.ndarray, powers: np.ndarray | None) -> np.ndarray:
        """∂a/∂q (N, 3, n_q) at one stage (its SRP column from the stage's Sun vector)."""
        N = d.shape[0]
        B = np.empty((N, 3, self.params.n_q))
        B[:, :, 0] = (self.params.srp_coefficient / (d2[:, 1] * np.sqrt(d2[:, 1])))[:, None] * d[:, 1, :]
        B[:, :, 1:N_Q_FIXED] = acs_part
        if powers is not None:
            B[:, :, N_Q_FIXED:] = 0.0
            B[:, self._poly_rows, self._poly_cols] = powers[:, self._poly_k]
        return B

    @overload
    def propagate(
        self, t0: float, t1: float, r: np.ndarray, v: np.ndarray, q: np.ndarray, with_stm: Literal[True] = ...
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    @overload
    def propagate(
        self, t0: float, t1: float, r: np.ndarray, v: np.ndarray, q: np.ndarray, with_stm: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]: ...

    def propagate(
        self, t0: float, t1: float, r: np.ndarray, v: np.ndarray, q: np.ndarray, with_stm: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Propagate (N, 3) r, v from t0 to t1 (either direction) with drivers q (N, n_q).

        Returns r(t1), v(t1) and Y(t1, t0) (N, 6, 6 + n_q) (None without ``with_stm``).

        Y follows RK4 on the variational equations. Where the gravity gradient is weak over a
        step — |G| h² (h|v|/|r| + 1e-4) < 1e-10, i.e. everywhere but the last day before
        entry — G and ∂a/∂q hardly change over the step (relative change h|v|/|r| from Mars,
        ~1e-4 from the Sun), and are frozen at the mid-step stage: RK4 of the variational
        equations then reduces to the closed form (A = [[0, I], [G, 0]])

            Φ = I + hA + (hA)²/2 + (hA)³/6 + (hA)⁴/24

        and the response Ψ to the drivers keeps RK4's stage weights of the forcing ∂a/∂q
        (:meth:`_frozen_gradient_step`). Its difference from the stage-by-stage integration is
        below the criterion's 1e-10 relative in Φ and in Ψ (checked against DOP853 on the
        variational equations in the tests) — for ~40 % of the step's cost.
        """
        N = r.shape[0]
        z = np.empty((N, 6))
        z[:, 0:3] = r
        z[:, 3:6] = v
        Y = None
        if with_stm:
            Y = np.zeros((N, 6, 6 + q.shape[1]))
            Y[:, [0, 1, 2, 3, 4, 5], [0, 1, 2, 3, 4, 5]] = 1.0
        total = t1 - t0
        if total == 0.0:
            return z[:, 0:3].copy(), z[:, 3:6].copy(), Y
        direction = 1.0 if total > 0 else -1.0
        params = self.params
        coeff = point_mass_coefficients(q, params)
        deg = params.poly_degree
        if deg is not None:
            t_batch = self._batch_start(t0 + 0.5 * total)
            poly = q[:, N_Q_FIXED:].reshape(N, deg + 1, 3)
        t = t0
        while True:
            remaining = t1 - t
            if remaining * direction <= 1e-9:
                break
            h = self.step_size(z[:, 0:3], z[:, 3:6])
            if abs(remaining) <= h * 1.000001:
                h = abs(remaining)
            else:
                # even out the steps left so the last one is not a sliver
                h = abs(remaining) / math.ceil(abs(remaining) / h)
            h *= direction
            t_mid, t_end = t + 0.5 * h, (t1 if abs(t1 - (t + h)) < 1e-9 else t + h)
            ep0, epm, ep1 = self.epoch(t), self.epoch(t_mid), self.epoch(t_end)
            # the cruise frame turns by < 1e-5 rad per step: one ACS evaluation per step
            a_acs, acs_part = acs_terms(z[:, 0:3], epm[0], q, params)
            kz: list[np.ndarray] = []
            kY: list[np.ndarray] = []
            forcing: list[np.ndarray] = []
            full = False
            # indirect third-body plus ACS acceleration: the same for every stage at one epoch
            extra0, extram, extra1 = ep0[2] + a_acs, epm[2] + a_acs, ep1[2] + a_acs
            for i, (c, tk, ep, extra) in enumerate(((0.0, t, ep0, extra0), (0.5, t_mid, epm, extram),
                                                    (0.5, t_mid, epm, extram), (1.0, t_end, ep1, extra1))):
                Xz = z if i == 0 else z + (c * h) * kz[-1]
                a, d, d2, w = point_masses(Xz[:, 0:3], ep[1], coeff)
                a += extra
                powers = None
                if deg is not None:
                    powers = poly_powers((tk - t_batch) / params.poly_batch_s, deg)
                    a += np.matmul(powers[:, None, :], poly)[:, 0, :]
                kz.append(np.concatenate((Xz[:, 3:6], a), axis=1))
                if Y is None:
                    continue
                if i == 0:
                    # |G| ≤ 2 Σ|c_k|/|d_k|³, first filter (the others differ by < 1 %)
                    g_max = 2.0 * sum(abs(c) for c in w[0].tolist())
                    rx, ry, rz, vx, vy, vz = z[0].tolist()
                    turn = abs(h) * math.sqrt((vx * vx + vy * vy + vz * vz) / (rx * rx + ry * ry + rz * rz))
                    full = g_max * h * h * (turn + 1e-4) >= self.frozen_gradient_tol
                if full:
                    XY = Y if i == 0 else Y + (c * h) * kY[-1]
                    kYi = np.empty_like(Y)
                    kYi[:, 0:3] = XY[:, 3:6]
                    np.matmul(point_mass_gradient(d, d2, w), XY[:, 0:3], out=kYi[:, 3:6])
                    kYi[:, 3:6, 6:] += self._forcing(d, d2, acs_part, powers)
                    kY.append(kYi)
                else:
                    # the forcing at the stages RK4 weights it with (start, middle, end)
                    if i == 1:
                        G_mid = point_mass_gradient(d, d2, w)
                    if i != 2:
                        forcing.append(self._forcing(d, d2, acs_part, powers))
            k1, k2, k3, k4 = kz
            z = z + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
            if Y is not None:
                if full:
                    k1, k2, k3, k4 = kY
                    Y = Y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
                else:
                    Y = self._frozen_gradient_step(Y, h, G_mid, *forcing)
            t = t_end
        return z[:, 0:3].copy(), z[:, 3:6].copy(), Y

    @staticmethod
    def _frozen_gradient_step(Y: np.ndarray, h: float, G: np.ndarray, B0: np.ndarray, Bm: np.ndarray,
                              B1: np.ndarray) -> np.ndarray:
        """Y ← [Φ Y_z | Φ Y_q + Ψ]: RK4 of the variational equations with G frozen at mid-step.

        The forcing B = ∂a/∂q keeps RK4's stage weights (it varies at first order: the Sun
        direction of the SRP column, the polynomial's time): Ψ_r = h²/6 (B₀ + 2B_m) + h⁴/24 G B_m,
        Ψ_v = h/6 (B₀ + 4B_m + B₁) + h³/6 G B_m."""
        N = Y.shape[0]
        h2 = h * h
        G2 = G @ G
        GB = G @ Bm
        diag = (0.5 * h2) * G + (h2 * h2 / 24.0) * G2
        Phi = np.empty((N, 6, 6))
        Phi[:, 0:3, 0:3] = diag
        Phi[:, 3:6, 3:6] = diag
        Phi[:, 0:3, 3:6] = (h2 * h / 6.0) * G
        Phi[:, 3:6, 0:3] = h * G + (h2 * h / 6.0) * G2
        Phi += _identity_with(h)
        out = Phi @ Y
        out[:, 0:3, 6:] += (h2 / 6.0) * (B0 + 2.0 * Bm) + (h2 * h2 / 24.0) * GB
        out[:, 3:6, 6:] += (h / 6.0) * (B0 + 4.0 * Bm + B1) + (h2 * h / 6.0) * GB
        return out

"""Trajectory and state-transition-matrix propagation for a stack of N filters at once.

The position/velocity z = [r, v] obeys ż = [v, a(r, q, t)] (forces in :mod:`fsw.models.forces`);
the acceleration drivers q are constant over a propagation interval (the filter splits its
propagation at batch boundaries). The sensitivity Y = ∂z(t)/∂[z(t0), q] (N, 6, 6 + n_q)
integrates with the state (variational equations):

    Ẏ_r = Y_v,    Ẏ_v = G Y_r + [0 | ∂a/∂q].

Classical fourth-order Runge–Kutta with a step of κ·min(√(r³/μ), r/|v|) — a fixed fraction of
the local dynamical time, so steps shrink automatically towards Mars — capped at ``max_step``.
Y integrated with the same stages is the exact derivative of the discrete RK map, so the
filter's STM is consistent with its trajectory to rounding. Third-body positions are looked up
once per distinct stage time (three per step) for the whole stack, and the direction of the
small ACS force (a cruise frame turning by < 1e-5 rad per step) once per step.
"""

from __future__ import annotations

import math

import numpy as np

from fsw.astro.constants import GM_MARS
from fsw.models.environment import Environment
from fsw.models.forces import ForceParameters, acceleration, acs_direction_icrf


class Propagator:
    """RK4 propagation of N trajectories and their sensitivities."""

    def __init__(self, env: Environment, params: ForceParameters, step_fraction: float = 0.02, max_step_s: float = 600.0):
        if not 0.0 < step_fraction <= 0.2 or max_step_s <= 0.0:
            raise ValueError("step_fraction must be in (0, 0.2] and max_step_s > 0")
        self.env = env
        self.params = params
        self.kappa = step_fraction
        self.max_step = max_step_s

    def step_size(self, r: np.ndarray, v: np.ndarray) -> float:
        rn = np.linalg.norm(r, axis=-1)
        vn = np.maximum(np.linalg.norm(v, axis=-1), 1e-9)
        scale = np.minimum(np.sqrt(rn**3 / GM_MARS), rn / vn)
        return min(self.max_step, self.kappa * float(np.min(scale)))

    def _batch_start(self, t: float) -> np.ndarray:
        T = self.params.poly_batch_s
        o = self.params.poly_origin_s
        return o + np.floor((t - o) / T) * T

    def _rhs(self, t: float, r, v, Y, q, bodies, t_batch, with_stm: bool, a_acs):
        s = None if self.params.poly_degree is None else (t - t_batch) / self.params.poly_batch_s
        a, G, dadq = acceleration(r, q, bodies, s, self.params, partials=with_stm, a_acs=a_acs)
        if not with_stm:
            return v, a, None
        dY = np.empty_like(Y)
        dY[:, :3, :] = Y[:, 3:, :]
        dY[:, 3:, :] = G @ Y[:, :3, :]
        dY[:, 3:, 6:] += dadq
        return v, a, dY

    def propagate(
        self, t0: float, t1: float, r: np.ndarray, v: np.ndarray, q: np.ndarray, with_stm: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Propagate (N, 3) r, v from t0 to t1 (either direction) with drivers q (N, n_q).

        Returns r(t1), v(t1) and Y(t1, t0) (N, 6, 6 + n_q) (None without ``with_stm``).
        """
        N = r.shape[0]
        nq = q.shape[1]
        r = np.array(r, dtype=float)
        v = np.array(v, dtype=float)
        Y = None
        if with_stm:
            Y = np.zeros((N, 6, 6 + nq))
            Y[:, [0, 1, 2, 3, 4, 5], [0, 1, 2, 3, 4, 5]] = 1.0
        total = t1 - t0
        if total == 0.0:
            return r, v, Y
        direction = 1.0 if total > 0 else -1.0
        t_batch = self._batch_start(t0 + 0.5 * total)
        t = t0
        bodies_t = self.env.third_bodies(t)
        while True:
            remaining = t1 - t
            if remaining * direction <= 1e-9:
                break
            h = self.step_size(r, v)
            if abs(remaining) <= h * 1.000001:
                h = abs(remaining)
            else:
                # even out the steps left so the last one is not a sliver
                h = abs(remaining) / math.ceil(abs(remaining) / h)
            h *= direction
            t_mid, t_end = t + 0.5 * h, (t1 if abs(t1 - (t + h)) < 1e-9 else t + h)
            bodies_mid = self.env.third_bodies(t_mid)
            # the cruise frame turns by < 1e-5 rad per step: one ACS direction per step
            a_acs = acs_direction_icrf(r, bodies_mid, self.params)
            bodies_end = self.env.third_bodies(t_end)
            k1r, k1v, k1Y = self._rhs(t, r, v, Y, q, bodies_t, t_batch, with_stm, a_acs)
            r2, v2 = r + 0.5 * h * k1r, v + 0.5 * h * k1v
            Y2 = Y + 0.5 * h * k1Y if with_stm else None
            k2r, k2v, k2Y = self._rhs(t_mid, r2, v2, Y2, q, bodies_mid, t_batch, with_stm, a_acs)
            r3, v3 = r + 0.5 * h * k2r, v + 0.5 * h * k2v
            Y3 = Y + 0.5 * h * k2Y if with_stm else None
            k3r, k3v, k3Y = self._rhs(t_mid, r3, v3, Y3, q, bodies_mid, t_batch, with_stm, a_acs)
            r4, v4 = r + h * k3r, v + h * k3v
            Y4 = Y + h * k3Y if with_stm else None
            k4r, k4v, k4Y = self._rhs(t_end, r4, v4, Y4, q, bodies_end, t_batch, with_stm, a_acs)
            r = r + (h / 6.0) * (k1r + 2.0 * (k2r + k3r) + k4r)
            v = v + (h / 6.0) * (k1v + 2.0 * (k2v + k3v) + k4v)
            if with_stm:
                Y = Y + (h / 6.0) * (k1Y + 2.0 * (k2Y + k3Y) + k4Y)
            t = t_end
            bodies_t = bodies_end
        return r, v, Y

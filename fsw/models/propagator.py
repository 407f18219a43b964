"""Trajectory and state-transition-matrix propagation for a stack of N filters at once.

The position/velocity z = [r, v] obeys ż = [v, a(r, q, t)] (forces in :mod:`fsw.models.forces`);
the acceleration drivers q are constant over a propagation interval (the filter splits its
propagation at batch boundaries). The sensitivity Y = ∂z(t)/∂[z(t0), q] (N, 6, 6 + n_q)
integrates with the state (variational equations):

    Ẏ_r = Y_v,    Ẏ_v = G Y_r + [0 | ∂a/∂q].

Classical fourth-order Runge–Kutta with a step of κ·min(√(r³/μ), r/|v|) — a fixed fraction of
the local dynamical time, so steps shrink automatically towards Mars — capped at ``max_step``.
Y integrated with the same stages is the exact derivative of the discrete RK map, so the
filter's STM is consistent with its trajectory to rounding.

The arithmetic is one compiled kernel per interval (:func:`fsw.kernels.variational_rk4.rk4_variational`):
the steps, the third bodies from the ephemeris table's Hermite interpolant, the forces and the
variational equations for all N filters, with no numpy call per step (a numpy step of (N, 6)
arrays cost ~170 µs of call overhead for ~6 kFLOP).
"""

from __future__ import annotations

from typing import Any, Literal, overload

import numpy as np

from fsw.astro.constants import GM_EARTH_MOON, GM_JUPITER_SYSTEM, GM_MARS, GM_SUN
from fsw.kernels.variational_rk4 import rk4_variational
from fsw.models.environment import Environment
from fsw.models.forces import ForceParameters

_GM = np.array([GM_MARS, GM_SUN, GM_EARTH_MOON, GM_JUPITER_SYSTEM])


class Propagator:
    """RK4 propagation of N trajectories and their sensitivities."""

    # slotted: see fsw.executive.FrameExecutive
    __slots__ = ("env", "params", "kappa", "max_step", "frozen_gradient_tol", "_srp", "_acs_nominal", "_acs_body",
                 "_poly_batch", "_deg", "_poly_origin")

    #: Bound on the relative STM change from freezing G over a step (see :meth:`propagate`);
    #: 0 integrates the variational equations stage by stage everywhere. Each propagator starts
    #: with it (its ``frozen_gradient_tol``).
    FROZEN_GRADIENT_TOL = 1e-10

    def __init__(self, env: Environment, params: ForceParameters, step_fraction: float = 0.02, max_step_s: float = 600.0):
        if not 0.0 < step_fraction <= 0.2 or max_step_s <= 0.0:
            raise ValueError("step_fraction must be in (0, 0.2] and max_step_s > 0")
        self.env = env
        self.params = params
        self.kappa = step_fraction
        self.max_step = max_step_s
        self.frozen_gradient_tol = self.FROZEN_GRADIENT_TOL
        self._srp = np.ascontiguousarray(params.srp_coefficient, dtype=float)
        self._acs_nominal = np.ascontiguousarray(params.acs_nominal, dtype=float)
        self._acs_body = np.ascontiguousarray(params.acs_body, dtype=float)
        self._poly_batch = np.ascontiguousarray(params.poly_batch_s, dtype=float)
        self._deg = -1 if params.poly_degree is None else int(params.poly_degree)
        self._poly_origin = float(params.poly_origin_s)

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

        and the response Ψ to the drivers keeps RK4's stage weights of the forcing ∂a/∂q.
        Its difference from the stage-by-stage integration is below the criterion's 1e-10
        relative in Φ and in Ψ (checked against DOP853 on the variational equations in the
        tests) — for ~40 % of the step's cost.
        """
        z = np.concatenate((r, v), axis=1)
        Y = np.empty((r.shape[0], 6, 6 + q.shape[1]))
        self.propagate_z(t0, t1, z, q if q.flags.c_contiguous else np.ascontiguousarray(q), Y, with_stm)
        return z[:, 0:3], z[:, 3:6], Y if with_stm else None

    def propagate_z(self, t0: float, t1: float, z: np.ndarray, q: np.ndarray, Y: np.ndarray,
                    with_stm: bool = True) -> None:
        """:meth:`propagate` in place for the hot loop: z = [r, v] (N, 6) from t0 to t1, Y (N, 6, 6 + n_q)
        filled (with ``with_stm``); z, q and Y float64 and C-contiguous."""
        args = (t0, t1, z, q, with_stm, *self.forces, *self.table(t0, t1), _GM, Y)
        rk4_variational(*args)

    @property
    def forces(self) -> tuple[Any, ...]:
        """The force model's arguments of :func:`~fsw.kernels.variational_rk4.rk4_variational`
        (``srp`` to ``frozen_tol``)."""
        return (self._srp, self._acs_nominal, self._acs_body, self._deg, self._poly_batch, self._poly_origin,
                self.kappa, self.max_step, self.frozen_gradient_tol)

    def table(self, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray, float, float]:
        """The ephemeris table covering a leg from t0 to t1 as the kernel reads it (``tab_p`` to
        ``tab_step``)."""
        lo, hi = (t0, t1) if t0 <= t1 else (t1, t0)
        return self.env.table_nodes(lo, hi)

    #: [μ_Mars, μ_Sun, μ_EMB, μ_Jupiter], the kernel's ``gm``.
    GM = _GM

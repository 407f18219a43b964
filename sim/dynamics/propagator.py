"""Numerical propagation of the truth trajectory and the queryable :class:`Trajectory`.

scipy ``solve_ivp`` (DOP853, dense output) is restarted at every discontinuity: batch edges of
the piecewise-constant SRP scale, ACS magnitudes and non-gravitational acceleration, and
impulsive burns. The integrator thus
never steps across a jump, and the dense output of each segment is smooth. Propagation runs
forwards or backwards; a burn at epoch t_m is applied as v(t_m+) = v(t_m-) + dv, so
``Trajectory.state(t_m)`` is the post-burn state.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from fsw.astro.ephemeris import EphemerisTable, default_ephemeris
from sim.dynamics.config import ForceModelConfig
from sim.dynamics.forces import TABLE_BODIES, cruise_attitude, make_rhs
from sim.dynamics.stochastic import DynamicsError, StochasticRealisation

if TYPE_CHECKING:
    from scipy.integrate import OdeSolution


def make_table(t_a: float, t_b: float, step_s: float = 1800.0) -> EphemerisTable:
    """The Mars-centred ephemeris table the truth dynamics read, covering [t_a, t_b] with margin."""
    lo, hi = min(t_a, t_b), max(t_a, t_b)
    return default_ephemeris().table(lo - 86400.0, hi + 86400.0, bodies=TABLE_BODIES, center="mars", step_s=step_s)


@dataclass(frozen=True)
class _Segment:
    t_lo: float
    t_hi: float
    sol: "OdeSolution"
    nfev: int
    ts_sorted: list  # the solver's step times, ascending (for the scalar fast path)


class Trajectory:
    """A propagated truth arc: dense state plus the realised force parameters.

    ``state(t)`` -> (6,) for scalar t or (N, 6) for t of shape (N,); position km, velocity
    km/s, Mars-centred ICRF. ``srp_scale(t)`` and ``acs_accel(t)`` give the realised truth of the
    stochastic forces (for the Truth message).
    """

    def __init__(self, segments: list[_Segment], realisation: StochasticRealisation,
                 forces: ForceModelConfig, table: EphemerisTable, final_state: np.ndarray) -> None:
        self._segments = sorted(segments, key=lambda s: s.t_lo)
        self._starts = np.array([s.t_lo for s in self._segments])
        self.t0: float = self._segments[0].t_lo
        self.t1: float = self._segments[-1].t_hi
        self.realisation = realisation
        self.forces = forces
        self.table = table
        # State where propagation stopped, after any burn there (backward: the pre-burn state).
        self.final_state = np.asarray(final_state, dtype=float)

    @property
    def nfev(self) -> int:
        """Right-hand-side evaluations spent building the trajectory."""
        return sum(s.nfev for s in self._segments)

    @property
    def n_segments(self) -> int:
        return len(self._segments)

    @property
    def maneuvers(self):
        return self.realisation.maneuvers

    def _times(self, t) -> tuple[np.ndarray, bool]:
        arr = np.asarray(t, dtype=float)
        scalar = arr.ndim == 0
        arr = np.atleast_1d(arr).ravel()
        if not np.all(np.isfinite(arr)):
            raise DynamicsError("non-finite time")
        tol = 1e-6
        if arr.size and (arr.min() < self.t0 - tol or arr.max() > self.t1 + tol):
            raise DynamicsError(f"time outside the trajectory span [{self.t0:.3f}, {self.t1:.3f}] s")
        return np.clip(arr, self.t0, self.t1), scalar

    def state(self, t) -> np.ndarray:
        """Mars-centred ICRF [x, y, z, vx, vy, vz] at t."""
        arr, scalar = self._times(t)
        idx = np.clip(np.searchsorted(self._starts, arr, side="right") - 1, 0, len(self._segments) - 1)
        out = np.empty((arr.size, 6))
        if scalar:
            # Straight to the step interpolant: OdeSolution.__call__ costs ~40 us per scalar call.
            seg = self._segments[int(idx[0])]
            j = min(max(bisect.bisect_left(seg.ts_sorted, arr[0]) - 1, 0), len(seg.ts_sorted) - 2)
            if not seg.sol.ascending:
                j = len(seg.ts_sorted) - 2 - j
            return seg.sol.interpolants[j](arr[0])
        for k in np.unique(idx):
            sel = idx == k
            out[sel] = self._segments[int(k)].sol(arr[sel]).T
        return out

    def position(self, t) -> np.ndarray:
        return self.state(t)[..., :3]

    def velocity(self, t) -> np.ndarray:
        return self.state(t)[..., 3:]

    def srp_scale(self, t):
        """Realised SRP scale factor at t."""
        arr, scalar = self._times(t)
        out = self.realisation.srp_scale_at(arr)
        return float(out[0]) if scalar else out

    def attitude(self, t) -> np.ndarray:
        """Cruise body axes in ICRF (columns x, y, z): (3, 3) or (N, 3, 3)."""
        arr, scalar = self._times(t)
        r = self.state(arr)[:, :3]
        p, _ = self.table.states(arr)
        m = cruise_attitude(r, p[:, 0], p[:, 1])
        return m[0] if scalar else m

    def nga_accel(self, t) -> np.ndarray:
        """Realised non-gravitational acceleration in ICRF [km/s^2]: (3,) or (N, 3)."""
        arr, scalar = self._times(t)
        out = self.realisation.nga_at(arr)
        return out[0] if scalar else out

    def acs_accel(self, t) -> np.ndarray:
        """Realised ACS acceleration in ICRF [km/s^2]: (3,) or (N, 3)."""
        arr, scalar = self._times(t)
        body = self.realisation.acs_body_vector_at(arr)
        out = np.einsum("nij,nj->ni", self.attitude(arr), body)
        return out[0] if scalar else out


def propagate(
    x0: np.ndarray,
    t_start: float,
    t_end: float,
    forces: ForceModelConfig,
    realisation: StochasticRealisation,
    table: EphemerisTable | None = None,
    rtol: float = 1e-12,
    atol_km: float = 1e-6,
    atol_km_s: float = 1e-12,
    carry_step: bool | None = None,
) -> Trajectory:
    """Integrate from (t_start, x0) to t_end (either direction) under ``forces``/``realisation``.

    The realisation must cover the span. Burns with epochs in [min, max) of the span are applied.
    ``carry_step``: start each segment with the step the previous one ended with instead of
    re-estimating it (None: only when the realisation has the hour-batched NGA).
    """
    # imported here: the scenario configuration imports this module in every process (0.25 s)
    from scipy.integrate import solve_ivp

    x = np.asarray(x0, dtype=float).reshape(-1)
    if x.shape != (6,) or not np.all(np.isfinite(x)):
        raise DynamicsError(f"initial state must be 6 finite numbers, got shape {np.shape(x0)}")
    if not (math.isfinite(t_start) and math.isfinite(t_end)) or t_start == t_end:
        raise DynamicsError("propagation span must be finite and non-empty")
    lo, hi = min(t_start, t_end), max(t_start, t_end)
    if realisation.t0 > lo + 1e-6 or realisation.t1 < hi - 1e-6:
        raise DynamicsError("the stochastic realisation does not cover the propagation span")
    if table is None:
        table = make_table(lo, hi)
    cuts = realisation.discontinuities()
    cuts = cuts[(cuts > lo) & (cuts < hi)]
    nodes = np.concatenate([[lo], cuts, [hi]])
    forward = t_end > t_start
    burns = {m.t_tdb: m.dv_km_s for m in realisation.maneuvers if lo <= m.t_tdb < hi}
    atol = np.array([atol_km] * 3 + [atol_km_s] * 3)

    order = range(len(nodes) - 1) if forward else range(len(nodes) - 2, -1, -1)
    segments: list[_Segment] = []
    # With hour-long NGA batches the segments are far shorter than the natural cruise step, and
    # re-estimating a (tiny) first step on every segment would cost most of the integration:
    # each segment then starts with the step the previous one ended with.
    if carry_step is None:
        carry_step = realisation.nga_edges is not None
    first_step: float | None = None
    for k in order:
        a, b = float(nodes[k]), float(nodes[k + 1])
        if forward and a in burns:
            x = x.copy()
            x[3:] += burns[a]
        mid = 0.5 * (a + b)
        nga = realisation.nga_at(mid) if realisation.nga_edges is not None else None
        rhs = make_rhs(forces, table, realisation.srp_scale_at(mid), realisation.acs_body_vector_at(mid), nga)
        span = (a, b) if forward else (b, a)
        if carry_step and first_step is not None:
            sol = solve_ivp(rhs, span, x, method="DOP853", rtol=rtol, atol=atol, dense_output=True,
                            first_step=min(first_step, b - a))
        else:
            sol = solve_ivp(rhs, span, x, method="DOP853", rtol=rtol, atol=atol, dense_output=True)
        if not sol.success:
            raise DynamicsError(f"integration failed on [{a}, {b}]: {sol.message}")
        steps = np.abs(np.diff(sol.t))
        first_step = float(steps[-2:].max()) if steps.size else None
        x = sol.y[:, -1]
        if not np.all(np.isfinite(x)) or np.linalg.norm(x[:3]) < 100.0:
            raise DynamicsError(f"trajectory left the valid domain near t = {span[1]}")
        segments.append(_Segment(a, b, sol.sol, int(sol.nfev), sorted(float(v) for v in sol.sol.ts)))
        if not forward and a in burns:
            x = x.copy()
            x[3:] -= burns[a]
    return Trajectory(segments, realisation, forces, table, x)

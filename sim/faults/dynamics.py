"""Dynamics faults: the truth trajectory changes from the fault onset, and only from then.

The nominal truth (``sim.trajectories.design.build_truth_trajectory``) is built first. For
thruster faults, the stochastic force realisation is redrawn from the *same* generator state
with the faulted :class:`~sim.dynamics.config.ForceModelConfig` (so every thruster keeps its
random bias and daily draws, scaled by the faulted sigmas), spliced into the nominal one inside
the fault windows (:func:`sim.faults.apply.splice_acs`), and the trajectory is propagated
forward from the nominal state at the first onset. Before the onset the faulted run *is* the
nominal run, bit for bit. Where two thruster faults overlap in time, the one listed last sets
the thruster magnitudes (they replace, they do not compound). An ``nga-level`` fault continues
the nominal NGA random sequence with its new steady-state sigma (:func:`sim.faults.apply.nga_level`).
"""

from __future__ import annotations

from typing import Callable

import dataclasses

import numpy as np

from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.dynamics.propagator import Trajectory, propagate
from sim.dynamics.stochastic import StochasticRealisation
from sim.faults.apply import FaultWindow, dynamics_windows, faulted_forces, nga_level, splice_acs


class SplicedTrajectory:
    """``before`` for t < t_split, ``after`` from t_split on (same interface as Trajectory)."""

    def __init__(self, before: Trajectory, after: Trajectory, t_split: float) -> None:
        self.before, self.after, self.t_split = before, after, float(t_split)
        self.t0, self.t1 = before.t0, after.t1
        self.realisation = after.realisation
        self.forces = after.forces
        self.table = before.table

    def _apply(self, name: str, t):
        arr = np.asarray(t, dtype=float)
        if arr.ndim == 0:
            return getattr(self.before if arr < self.t_split else self.after, name)(float(arr))
        arr = arr.ravel()
        late = arr >= self.t_split
        parts = {}
        if (~late).any():
            parts[False] = np.asarray(getattr(self.before, name)(arr[~late]))
        if late.any():
            parts[True] = np.asarray(getattr(self.after, name)(arr[late]))
        sample = next(iter(parts.values()))
        out = np.empty((arr.size,) + sample.shape[1:], dtype=sample.dtype)
        for flag, values in parts.items():
            out[late == flag] = values
        return out

    def state(self, t):
        return self._apply("state", t)

    def position(self, t):
        return self._apply("position", t)

    def velocity(self, t):
        return self._apply("velocity", t)

    def srp_scale(self, t):
        return self._apply("srp_scale", t)

    def acs_accel(self, t):
        return self._apply("acs_accel", t)

    def nga_accel(self, t):
        return self._apply("nga_accel", t)

    def attitude(self, t):
        return self._apply("attitude", t)

    @property
    def maneuvers(self):
        return self.after.maneuvers


def apply_dynamics_faults(
    nominal: Trajectory,
    traj_cfg: TrajectoryConfig,
    forces: ForceModelConfig,
    windows: tuple[FaultWindow, ...],
    same_generator: Callable[[], np.random.Generator],
):
    """The truth trajectory with the dynamics faults among ``windows`` (``nominal`` if none).

    ``same_generator()`` must return a generator in the state the nominal trajectory's
    realisation was drawn from (a fresh generator on the same seed sequence).
    """
    dyn = tuple(w for w in dynamics_windows(windows) if w.t_on < nominal.t1)
    if not dyn:
        return nominal
    t0, t1 = nominal.realisation.t0, nominal.realisation.t1
    thrusters = tuple(w for w in dyn if w.config.type != "nga-level")
    spliced = nominal.realisation
    f_forces = forces
    if thrusters:
        # the thruster draws come from the trajectory generator; the NGA has its own stream
        no_nga = dataclasses.replace(forces, nga_sigma_km_s2=0.0)
        check = StochasticRealisation.draw(no_nga, t0, t1, same_generator())
        if not (np.array_equal(check.acs_magnitudes, nominal.realisation.acs_magnitudes)
                and np.array_equal(check.srp_scale, nominal.realisation.srp_scale)):
            raise RuntimeError("the nominal truth was not drawn from the generator state given for the faults")
        faulted = []
        for w in thrusters:
            f_forces_w = faulted_forces(no_nga, w)
            faulted.append((w, StochasticRealisation.draw(f_forces_w, t0, t1, same_generator())))
            f_forces = faulted_forces(forces, w)
        spliced = splice_acs(spliced, faulted)
    if any(w.config.type == "nga-level" for w in dyn):
        spliced = nga_level(spliced, forces.nga_sigma_km_s2, dyn)
    t_on = max(min(w.t_on for w in dyn), nominal.t0)
    if t_on <= nominal.t0:
        x_on = nominal.state(nominal.t0)
    else:
        x_on = nominal.state(t_on)
    after = propagate(x_on, t_on, nominal.t1, f_forces, spliced, nominal.table,
                      traj_cfg.rtol, traj_cfg.atol_km, traj_cfg.atol_km_s)
    if t_on <= nominal.t0:
        return after
    return SplicedTrajectory(nominal, after, t_on)

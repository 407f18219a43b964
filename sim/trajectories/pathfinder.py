"""Built-in trajectory ``pathfinder-cruise``: a Mars Pathfinder-like Type-I Earth-Mars cruise.

Construction (Chaer et al. 1998 §V flies the Mars Pathfinder cruise; launch 1996-12-04 06:58:07 UTC,
Mars arrival 1997-07-04, public NASA/JPL facts):

1. Lambert (Sun two-body, zero revolutions, prograde short way; :mod:`sim.trajectories.lambert`)
   from Earth's heliocentric position at launch to Mars' at arrival (DE421 through
   :mod:`fsw.astro.ephemeris`): the Type-I conic, ~212 days, transfer angle < 180 deg.
2. The conic state ``cruise_start_offset_days`` after launch (Kepler propagation along the
   conic), made Mars-centred. From there the *design* force model (every dispersion off, NGA
   off: the truth dynamics of :mod:`sim.dynamics`, Mars-centred with Sun, Earth-Moon barycentre
   and Jupiter as third bodies, cannonball SRP) takes over. The Earth's pull over the first days
   (the conic ignores it) would make the full-force arc miss Mars by millions of km, so the
   initial velocity is corrected (quasi-Newton, Jacobian of the Sun-only conic) until the
   full-force arc passes within 1 km of the conic's position ``aim_days_before_arrival`` before
   arrival (aiming at Mars' centre itself would be singular). The arc therefore heads for Mars
   like the real cruise, without the final approach targeting.
3. The truth run starts from that state under a drawn realisation of the stochastic forces
   (SRP scale factor, NGA), so it drifts from the design as a real cruise does.

Precision of the Mars-centred integration over a cruise: the indirect (Mars-acceleration) terms
of the Sun (~2.6e-6 km/s^2) are subtracted from the direct ones in float64, which loses
nothing above ~1e-21 km/s^2, ten orders below the NGA levels; positions of ~3e8 km carry
~6e-8 km of rounding. Earth is the Earth-Moon barycentre point mass in both the truth and the
onboard model: the Moon's offset changes the acceleration by ~1e-10 km/s^2 at the first pass
(day 7, ~2e6 km from Earth) and falls as r^-4 (below 1e-12 km/s^2 after ~3 weeks).
"""

from __future__ import annotations

import dataclasses
from functools import lru_cache

import numpy as np

from fsw.astro.constants import GM_SUN, SECONDS_PER_DAY
from fsw.astro.ephemeris import default_ephemeris
from sim.truth.timescales import utc_iso_to_tdb
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.dynamics.propagator import Trajectory, make_table, propagate
from sim.dynamics.stochastic import DynamicsError, StochasticRealisation
from sim.trajectories.lambert import kepler, lambert

NAME = "pathfinder-cruise"
_AIM_TOLERANCE_KM = 1.0
_MAX_ITERATIONS = 12


def cruise_span(cfg: TrajectoryConfig) -> tuple[float, float]:
    """(t_start, t_end) TDB of the simulated cruise arc."""
    t_launch = utc_iso_to_tdb(cfg.launch_epoch())
    t_arrival = utc_iso_to_tdb(cfg.arrival_epoch())
    t0 = t_launch + cfg.cruise_start_offset_days * SECONDS_PER_DAY
    t1 = t0 + cfg.span_days * SECONDS_PER_DAY
    if not t_arrival > t_launch:
        raise DynamicsError("arrival must be after launch")
    if t1 > t_arrival - cfg.aim_days_before_arrival * SECONDS_PER_DAY:
        raise DynamicsError("the cruise arc must end before the aim point (arrival - aim_days_before_arrival)")
    return t0, t1


def transfer_conic(cfg: TrajectoryConfig) -> tuple[float, np.ndarray, np.ndarray, float]:
    """(t_launch, r_earth, v_departure, t_arrival): heliocentric ICRF Lambert departure state."""
    eph = default_ephemeris()
    t_launch = utc_iso_to_tdb(cfg.launch_epoch())
    t_arrival = utc_iso_to_tdb(cfg.arrival_epoch())
    r_earth, _ = eph.state("earth", t_launch, "sun")
    r_mars, _ = eph.state("mars", t_arrival, "sun")
    v1, _ = lambert(r_earth, r_mars, t_arrival - t_launch, GM_SUN)
    return t_launch, r_earth, v1, t_arrival


def conic_state(cfg: TrajectoryConfig, t: float) -> np.ndarray:
    """Heliocentric ICRF state [km, km/s] of the Lambert conic at TDB t."""
    t_launch, r_earth, v1, _ = transfer_conic(cfg)
    r, v = kepler(r_earth, v1, t - t_launch, GM_SUN)
    return np.concatenate([r, v])


def design_forces(forces: ForceModelConfig) -> ForceModelConfig:
    """The deterministic force model the trajectory is designed with."""
    return dataclasses.replace(forces.without_dispersions(), acs_scale=1.0)


def _sun_from_mars(t: float) -> np.ndarray:
    p, v = default_ephemeris().state("sun", t, "mars")
    return np.concatenate([p, v])


@lru_cache(maxsize=16)
def _initial_state_cached(cfg: TrajectoryConfig, forces: ForceModelConfig) -> tuple[float, tuple[float, ...], float]:
    t0, _ = cruise_span(cfg)
    t_arrival = utc_iso_to_tdb(cfg.arrival_epoch())
    t_aim = t_arrival - cfg.aim_days_before_arrival * SECONDS_PER_DAY
    helio0 = conic_state(cfg, t0)
    target = conic_state(cfg, t_aim)[:3] + _sun_from_mars(t_aim)[:3]
    # Jacobian d r(t_aim) / d v(t0) of the Sun-only conic (central differences)
    J = np.empty((3, 3))
    dv = 1e-5
    for k in range(3):
        e = np.zeros(3)
        e[k] = dv
        rp, _ = kepler(helio0[:3], helio0[3:] + e, t_aim - t0, GM_SUN)
        rm, _ = kepler(helio0[:3], helio0[3:] - e, t_aim - t0, GM_SUN)
        J[:, k] = (rp - rm) / (2 * dv)
    x0 = helio0 + _sun_from_mars(t0)
    real = StochasticRealisation.nominal(forces, t0, t_aim)
    table = make_table(t0, t_aim, cfg.ephemeris_step_s)
    miss = np.inf
    prev: tuple[np.ndarray, np.ndarray] | None = None
    for _ in range(_MAX_ITERATIONS):
        arc = propagate(x0, t0, t_aim, forces, real, table, cfg.rtol, cfg.atol_km, cfg.atol_km_s, carry_step=True)
        err = arc.final_state[:3] - target
        miss = float(np.linalg.norm(err))
        if miss < _AIM_TOLERANCE_KM:
            break
        if prev is not None:
            # Broyden's update: the Earth's pull makes the true Jacobian differ from the conic's
            d_v, d_err = x0[3:] - prev[0], err - prev[1]
            J = J + np.outer(d_err - J @ d_v, d_v) / float(d_v @ d_v)
        prev = (x0[3:].copy(), err)
        x0 = x0.copy()
        x0[3:] -= np.linalg.solve(J, err)
    if miss >= _AIM_TOLERANCE_KM:
        raise DynamicsError(f"cruise design did not converge: miss {miss:.1f} km at the aim point")
    return t0, tuple(float(v) for v in x0), miss


def pathfinder_initial_state(
    cfg: TrajectoryConfig = TrajectoryConfig(kind="pathfinder-cruise", span_days=120.0),
    forces: ForceModelConfig = ForceModelConfig(),
) -> tuple[float, np.ndarray]:
    """(t0_tdb, Mars-centred ICRF state at the cruise start) of the design trajectory."""
    t0, x0, _ = _initial_state_cached(cfg, design_forces(forces))
    return t0, np.array(x0)


def design_miss_km(cfg: TrajectoryConfig, forces: ForceModelConfig) -> float:
    """Distance [km] of the design arc from the conic at the aim point (diagnostics)."""
    return _initial_state_cached(cfg, design_forces(forces))[2]


def build_truth_trajectory(
    cfg: TrajectoryConfig, forces: ForceModelConfig, rng: np.random.Generator | None,
    nga_rng: np.random.Generator | None = None, initial: tuple[float, np.ndarray] | None = None,
) -> Trajectory:
    """The truth arc from the design initial state under one draw of the stochastic forces."""
    # the design state, if the caller has it
    t0, x0 = pathfinder_initial_state(cfg, forces) if initial is None else initial
    _, t1 = cruise_span(cfg)
    real = StochasticRealisation.draw(forces, t0, t1, rng, nga_rng)
    table = make_table(t0, t1, cfg.ephemeris_step_s)
    return propagate(x0, t0, t1, forces, real, table, cfg.rtol, cfg.atol_km, cfg.atol_km_s)

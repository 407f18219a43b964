"""Built-in trajectory ``insight-approach``: the last 45 days of InSight's Mars approach.

Construction (the entry state is the anchor, as in an EDL design):

1. The entry state in Mars-centred ICRF from the entry epoch, interface radius, inertial
   flight-path angle and speed, and the entry point (planetocentric latitude, IAU east
   longitude, turned into inertial space with the IAU 2009 prime meridian W(t)) and inertial
   heading (azimuth clockwise from north). See :class:`TrajectoryConfig` for the numbers.
2. Back-propagation over ``span_days`` with the truth dynamics of the *design* force model:
   every dispersion off, ACS at its nominal magnitude (``acs_scale`` 1), planned burns.
3. The truth run starts from that initial state with a drawn realisation of the stochastic
   forces, so it reaches the entry interface only approximately: that miss is what the
   navigation filters must find.

The default entry point and heading make the incoming asymptote that of a Type-I transfer: the
initial state's heliocentric osculating orbit has perihelion ~1 AU and passes near Earth at
InSight's launch (2018-05-05) — checked in the tests.
"""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache

import numpy as np

from fsw.astro.constants import GM_MARS, SECONDS_PER_DAY
from sim.truth.mars import areocentric_to_body_fixed, body_fixed_to_icrf_matrix
from sim.truth.timescales import utc_iso_to_tdb
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.dynamics.propagator import Trajectory, make_table, propagate
from sim.dynamics.stochastic import StochasticRealisation

NAME = "insight-approach"


def entry_state(cfg: TrajectoryConfig) -> tuple[float, np.ndarray]:
    """(t_entry_tdb, Mars-centred ICRF state at the entry interface)."""
    t_e = utc_iso_to_tdb(cfg.entry_epoch_utc)
    lat, lon = math.radians(cfg.entry_latitude_deg), math.radians(cfg.entry_longitude_deg)
    M = body_fixed_to_icrf_matrix(t_e)
    r = M @ areocentric_to_body_fixed(lat, lon, cfg.entry_radius_km)
    up = r / np.linalg.norm(r)
    pole = M[:, 2]
    east = np.cross(pole, up)
    east /= np.linalg.norm(east)
    north = np.cross(up, east)
    g, az = math.radians(cfg.entry_fpa_deg), math.radians(cfg.entry_azimuth_deg)
    v = cfg.entry_speed_km_s * (math.sin(g) * up + math.cos(g) * (math.cos(az) * north + math.sin(az) * east))
    return t_e, np.concatenate([r, v])


def design_forces(forces: ForceModelConfig) -> ForceModelConfig:
    """The deterministic force model the trajectory is designed with."""
    return dataclasses.replace(forces.without_dispersions(), acs_scale=1.0)


@lru_cache(maxsize=16)
def _initial_state_cached(cfg: TrajectoryConfig, forces: ForceModelConfig) -> tuple[float, tuple[float, ...]]:
    t_e, x_e = entry_state(cfg)
    t0 = t_e - cfg.span_days * SECONDS_PER_DAY
    design = forces  # already the design model (see insight_initial_state)
    real = StochasticRealisation.nominal(design, t0, t_e)
    table = make_table(t0, t_e, cfg.ephemeris_step_s)
    back = propagate(x_e, t_e, t0, design, real, table, cfg.rtol, cfg.atol_km, cfg.atol_km_s)
    return t0, tuple(float(v) for v in back.final_state)


def insight_initial_state(
    cfg: TrajectoryConfig = TrajectoryConfig(), forces: ForceModelConfig = ForceModelConfig()
) -> tuple[float, np.ndarray]:
    """(t0_tdb, Mars-centred ICRF state span_days before entry) of the design trajectory."""
    t0, x0 = _initial_state_cached(cfg, design_forces(forces))
    return t0, np.array(x0)


def build_truth_trajectory(
    cfg: TrajectoryConfig, forces: ForceModelConfig, rng: np.random.Generator | None,
    nga_rng: np.random.Generator | None = None, initial: tuple[float, np.ndarray] | None = None,
) -> Trajectory:
    """The truth arc from the design initial state under one draw of the stochastic forces.

    ``rng`` may be None only when ``forces`` has no dispersions; ``nga_rng`` is needed only
    with a non-gravitational acceleration.
    """
    # the design state, if the caller has it
    t0, x0 = insight_initial_state(cfg, forces) if initial is None else initial
    t1 = t0 + cfg.span_days * SECONDS_PER_DAY
    real = StochasticRealisation.draw(forces, t0, t1, rng, nga_rng)
    table = make_table(t0, t1, cfg.ephemeris_step_s)
    return propagate(x0, t0, t1, forces, real, table, cfg.rtol, cfg.atol_km, cfg.atol_km_s)


def hyperbolic_excess_speed(x: np.ndarray) -> float:
    """v_inf [km/s] of a Mars-centred state from the two-body energy (nan if bound)."""
    r = float(np.linalg.norm(x[:3]))
    energy = 0.5 * float(np.dot(x[3:], x[3:])) - GM_MARS / r
    return math.sqrt(2 * energy) if energy > 0 else math.nan


def plot_approach(trajectory: Trajectory, path: str, n: int = 2000) -> None:
    """Save a PNG of the approach geometry (Mars-centred ICRF, km): two projections + range."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.linspace(trajectory.t0, trajectory.t1, n)
    x = trajectory.state(t)
    days = (t - trajectory.t1) / SECONDS_PER_DAY
    sun = trajectory.table.states(t)[0][:, 0]
    earth = trajectory.table.states(t)[0][:, 1]
    fig, axes = plt.subplots(1, 4, figsize=(21, 5.2))
    for ax, (i, j), label in zip(axes[:2], ((0, 1), (0, 2)), (("X", "Y"), ("X", "Z"))):
        ax.plot(x[:, i] / 1e6, x[:, j] / 1e6, lw=1.5, label="spacecraft")
        ax.plot(0, 0, "o", color="tab:red", ms=6, label="Mars")
        ax.plot(x[0, i] / 1e6, x[0, j] / 1e6, "s", color="tab:green", label=f"start (E{days[0]:.0f} d)")
        for body, vec, col in (("Sun", sun, "gold"), ("Earth", earth, "tab:blue")):
            u = vec[0] / np.linalg.norm(vec[0]) * np.max(np.abs(x[:, [i, j]])) / 1e6 * 0.6
            ax.annotate("", xy=(u[i], u[j]), xytext=(0, 0), arrowprops=dict(arrowstyle="->", color=col))
            ax.text(u[i], u[j], f"to {body}", color=col)
        ax.set_xlabel(f"ICRF {label[0]} [10^6 km]")
        ax.set_ylabel(f"ICRF {label[1]} [10^6 km]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    rng = np.linalg.norm(x[:, :3], axis=1)
    axes[2].semilogy(days, rng, lw=1.5)
    for m in trajectory.maneuvers:
        axes[2].axvline((m.t_tdb - trajectory.t1) / SECONDS_PER_DAY, color="tab:orange", ls="--", lw=1)
    axes[2].set_xlabel("days to entry")
    axes[2].set_ylabel("distance from Mars centre [km]")
    axes[2].grid(alpha=0.3, which="both")
    # Last two days, projected on the approach plane (normal = angular momentum at entry).
    t_last = np.linspace(max(trajectory.t0, trajectory.t1 - 2 * SECONDS_PER_DAY), trajectory.t1, 800)
    xl = trajectory.state(t_last)
    h = np.cross(xl[-1, :3], xl[-1, 3:])
    e3 = h / np.linalg.norm(h)
    e1 = xl[-1, :3] / np.linalg.norm(xl[-1, :3])
    e2 = np.cross(e3, e1)
    ax = axes[3]
    ax.plot(xl[:, :3] @ e1 / 1e3, xl[:, :3] @ e2 / 1e3, lw=1.5, label="last 2 days")
    ang = np.linspace(0, 2 * np.pi, 200)
    from fsw.astro.constants import R_MARS_EQ_KM

    ax.fill(R_MARS_EQ_KM * np.cos(ang) / 1e3, R_MARS_EQ_KM * np.sin(ang) / 1e3, color="tab:red", alpha=0.5, label="Mars")
    ax.plot(xl[-1, :3] @ e1 / 1e3, xl[-1, :3] @ e2 / 1e3, "x", color="k", label="entry interface")
    ax.set_xlabel("along entry radius [10^3 km]")
    ax.set_ylabel("along-track, approach plane [10^3 km]")
    ax.set_ylim(-70, 10)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    vinf = hyperbolic_excess_speed(x[-1])
    fig.suptitle(f"{NAME}: Mars-centred ICRF approach, entry r = {rng[-1]:.1f} km, "
                 f"|v| = {np.linalg.norm(x[-1, 3:]):.3f} km/s, v_inf = {vinf:.2f} km/s")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

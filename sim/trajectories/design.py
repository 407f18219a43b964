"""The built-in trajectory a :class:`~sim.dynamics.config.TrajectoryConfig` selects (``kind``).

One entry point per question the rest of the system asks: the arc's span, the design initial
state (uplinked, with an a-priori error, to the flight software) and the truth arc.
"""

from __future__ import annotations

import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY
from sim.truth.timescales import utc_iso_to_tdb
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.dynamics.propagator import Trajectory
from sim.trajectories import insight, pathfinder
from sim.trajectories.design_cache import cached_state


def arc_span(cfg: TrajectoryConfig) -> tuple[float, float]:
    """(t_start, t_end) TDB of the simulated arc."""
    if cfg.kind == "pathfinder-cruise":
        return pathfinder.cruise_span(cfg)
    if cfg.kind == "insight-approach":
        t_end = utc_iso_to_tdb(cfg.entry_epoch_utc)
        return t_end - cfg.span_days * SECONDS_PER_DAY, t_end
    raise ValueError(f"unknown trajectory kind {cfg.kind!r}")


def initial_state(cfg: TrajectoryConfig, forces: ForceModelConfig) -> tuple[float, np.ndarray]:
    """(t0_tdb, Mars-centred ICRF state) of the design trajectory at the start of the arc, kept
    on disk between processes (:mod:`sim.trajectories.design_cache`)."""
    if cfg.kind == "pathfinder-cruise":
        design = pathfinder.pathfinder_initial_state
    elif cfg.kind == "insight-approach":
        design = insight.insight_initial_state
    else:
        raise ValueError(f"unknown trajectory kind {cfg.kind!r}")

    def compute() -> tuple[float, tuple[float, ...]]:
        t0, x0 = design(cfg, forces)
        return t0, tuple(x0)

    t0, x0 = cached_state(cfg, forces, compute)
    return t0, np.array(x0)


def build_truth_trajectory(
    cfg: TrajectoryConfig, forces: ForceModelConfig, rng: np.random.Generator | None,
    nga_rng: np.random.Generator | None = None,
) -> Trajectory:
    """The truth arc under one draw of the stochastic forces (``nga_rng``: the NGA's own stream),
    from the design initial state (:func:`initial_state`: kept between processes)."""
    if cfg.kind == "pathfinder-cruise":
        return pathfinder.build_truth_trajectory(cfg, forces, rng, nga_rng, initial_state(cfg, forces))
    if cfg.kind == "insight-approach":
        return insight.build_truth_trajectory(cfg, forces, rng, nga_rng, initial_state(cfg, forces))
    raise ValueError(f"unknown trajectory kind {cfg.kind!r}")

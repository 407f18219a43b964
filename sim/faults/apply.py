"""Applying faults: measurement biases, clock steps, truth-dynamics changes, and their records.

Each :class:`~sim.faults.config.FaultConfig` becomes a :class:`FaultWindow` in TDB seconds
(``t_on = t_start + onset_day * 86400``, end likewise or open). A fault is active at true time t
when ``t_on <= t < t_off``. Measurement biases are added to the reported values of the kinds
they name; the clock bias is a :class:`~sim.clock.ClockStep` of the clock truth; the thruster
faults change the truth force realisation from their onset (:func:`splice_acs`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, cast

import numpy as np

from fsw.astro.constants import MHZ_TO_KM_S, SECONDS_PER_DAY
from sim.truth.timescales import tdb_to_unix
from fsw.interface.messages import FaultEvent, Stamp
from sim.clock import ClockStep
from sim.dynamics.stochastic import StochasticRealisation
from sim.faults.config import FaultConfig, fault_ids


@dataclass(frozen=True)
class FaultWindow:
    """A fault with its identifier and its window in TDB seconds past J2000."""

    id: str
    config: FaultConfig
    t_on: float
    t_off: float | None

    def active(self, t) -> np.ndarray:
        """Boolean mask: the fault is active at true TDB times t."""
        t = np.asarray(t, dtype=float)
        on = t >= self.t_on
        if self.t_off is not None:
            on &= t < self.t_off
        return on


def fault_windows(faults: tuple[FaultConfig, ...], t_start: float) -> tuple[FaultWindow, ...]:
    """Windows of the faults of a run starting at TDB ``t_start``."""
    ids = fault_ids(tuple(faults))
    return tuple(
        FaultWindow(
            id=i,
            config=f,
            t_on=t_start + f.onset_day * SECONDS_PER_DAY,
            t_off=None if f.end_day is None else t_start + f.end_day * SECONDS_PER_DAY,
        )
        for i, f in zip(ids, faults)
    )


def range_bias_km(windows: tuple[FaultWindow, ...], t) -> np.ndarray:
    """Bias [km] added to range measurements received at true times t."""
    t = np.asarray(t, dtype=float)
    out = np.zeros(t.shape)
    for w in windows:
        if w.config.type == "range-bias":
            out += np.where(w.active(t), cast(float, w.config.range_m) * 1e-3, 0.0)  # set for this type
    return out


def doppler_bias_km_s(windows: tuple[FaultWindow, ...], t) -> np.ndarray:
    """Bias [km/s] added to Doppler (range-rate) measurements: -doppler_mhz x MHZ_TO_KM_S.

    The minus sign follows the one-way convention f_D = -(F/c) range_rate: a higher received
    frequency shift means a lower range rate (see :mod:`sim.faults.config`).
    """
    t = np.asarray(t, dtype=float)
    out = np.zeros(t.shape)
    for w in windows:
        if w.config.type == "doppler-bias":
            out += np.where(w.active(t), -cast(float, w.config.doppler_mhz) * MHZ_TO_KM_S, 0.0)  # set for this type
    return out


def optical_bias_px(windows: tuple[FaultWindow, ...], t) -> np.ndarray:
    """Bias (N, 2) [sample, line] px added to optical centroids at true times t."""
    t = np.asarray(t, dtype=float)
    out = np.zeros(t.shape + (2,))
    for w in windows:
        if w.config.type == "optical-bias":
            on = w.active(t)[..., None]
            out += np.where(on, np.array([w.config.sample_px, w.config.line_px]), 0.0)
    return out


def clock_steps(windows: tuple[FaultWindow, ...]) -> tuple[ClockStep, ...]:
    """The clock misbehaviours of the clock-bias faults."""
    return tuple(
        ClockStep(t_on=w.t_on, t_off=w.t_off, phase_s=w.config.phase_s or 0.0, frequency=w.config.frequency or 0.0)
        for w in windows
        if w.config.type == "clock-bias"
    )


def dynamics_windows(windows: tuple[FaultWindow, ...]) -> tuple[FaultWindow, ...]:
    """The faults that change the truth dynamics."""
    return tuple(w for w in windows if w.config.type in ("thruster-mismodel", "thruster-scale", "nga-level"))


def faulted_forces(forces, window: FaultWindow):
    """The force-model configuration in force while a dynamics fault is active.

    ``thruster-mismodel`` sets the per-thruster bias and daily sigmas to the given multiples of
    the nominal level (Lubey & Ely 2022 §4.4); ``thruster-scale`` multiplies the true ACS magnitude;
    ``nga-level`` sets the NGA steady-state sigma.
    """
    c = window.config
    if c.type == "nga-level":
        return dataclasses.replace(forces, nga_sigma_km_s2=c.sigma_km_s2)
    if c.type == "thruster-mismodel":
        return dataclasses.replace(forces, acs_bias_sigma_rel=c.bias_sigma_factor, acs_daily_sigma_rel=c.daily_sigma_factor)
    if c.type == "thruster-scale":
        return dataclasses.replace(forces, acs_scale=forces.acs_scale * c.scale)
    raise ValueError(f"{c.type} is not a dynamics fault")


def splice_acs(nominal: StochasticRealisation,
               faulted_by_window: Sequence[tuple[FaultWindow, StochasticRealisation]]) -> StochasticRealisation:
    """ACS realisation that is ``nominal`` outside the fault windows and the faulted one inside.

    ``nominal`` and each faulted realisation must come from the same random draws (same
    generator state), so they differ only by the fault's parameters: inside a window the
    thrusters keep their random bias and daily draws, scaled by the faulted sigmas. Batches
    are split at the window edges so the change happens exactly at onset.
    """
    edges = nominal.acs_edges
    cuts = [w.t_on for w, _ in faulted_by_window] + [w.t_off for w, _ in faulted_by_window if w.t_off is not None]
    cuts = [c for c in cuts if edges[0] < c < edges[-1]]
    new_edges = np.unique(np.concatenate([edges, cuts]))
    starts = new_edges[:-1]
    src = np.clip(np.searchsorted(edges, starts, side="right") - 1, 0, edges.size - 2)
    mags = nominal.acs_magnitudes[:, src].copy()
    dirs = nominal.acs_directions_body
    for w, real in faulted_by_window:
        on = w.active(starts)
        if not np.allclose(real.acs_directions_body, dirs, rtol=0, atol=1e-15):
            raise ValueError("faulted realisation was not drawn from the same random state")
        mags[:, on] = real.acs_magnitudes[:, src][:, on]
    return dataclasses.replace(nominal, acs_edges=new_edges, acs_magnitudes=mags)


def nga_level(realisation, base_sigma: float, windows: tuple[FaultWindow, ...]):
    """The realisation with its NGA continued at the ``nga-level`` windows' sigmas.

    A batch takes the sigma of the window active at its start (the last listed wins where
    windows overlap), ``base_sigma`` elsewhere: the change happens at the first NGA batch edge at
    or after the onset. The NGA normals are kept (see :mod:`sim.faults.config`)."""
    if realisation.nga_edges is None:
        raise ValueError("an nga-level fault needs the non-gravitational acceleration on (nga_sigma_km_s2 > 0)")
    starts = realisation.nga_edges[:-1]
    sigma = np.full(starts.size, float(base_sigma))
    for w in windows:
        if w.config.type == "nga-level":
            sigma[w.active(starts)] = w.config.sigma_km_s2
    return realisation.with_nga_sigma(sigma)


def fault_events(windows: tuple[FaultWindow, ...], t_end: float) -> list[FaultEvent]:
    """Start (and end, if inside the run) events of every fault, in time order."""
    events = []
    for w in windows:
        edges: tuple[tuple[float | None, Literal["start", "end"]], ...] = ((w.t_on, "start"), (w.t_off, "end"))
        for t, kind in edges:
            if t is None or t > t_end:
                continue
            events.append(FaultEvent(
                t_s=float(t),
                timestamp=Stamp.from_unix(float(tdb_to_unix(t))),
                fault_id=w.id,
                fault_type=w.config.type,
                event=kind,
                fault_class=w.config.fault_class,
                magnitude=w.config.magnitude(),
            ))
    events.sort(key=lambda e: (e.t_s, e.event != "end"))
    return events


def active_ids(windows: tuple[FaultWindow, ...], t) -> list[tuple[str, ...]]:
    """Per time, the identifiers of the faults active then."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    masks = [(w.id, w.active(t)) for w in windows]
    return [tuple(i for i, m in masks if m[k]) for k in range(t.size)]

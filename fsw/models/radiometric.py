"""One-way uplink range and Doppler as measured on board, with exact partials.

Geometry (Lubey & Ely 2022 §4.1, one-way radiometric data with a DSAC-class onboard clock). A DSN
station transmits at TDB t_tx; the spacecraft receives at true TDB t_rx and time-tags the
reception with its own clock, t_tag = t_rx + δ, δ the clock phase error (clock minus TDB). The
light-time equation is solved in the solar-system-barycentric (SSB) frame:

    c (t_rx − t_tx) = ρ_g = |r_sc,B(t_rx) − r_st,B(t_tx)|.

The measured pseudo-range compares the reception clock reading with the transmit time::

    ρ = c (t_tag − t_tx) = c (t_rx + δ − t_tx) = ρ_g + c δ (+ range bias b).

The filter propagates to the time tag, so with its state (r, v) at t_tag (Mars-centred) the
spacecraft at reception is r_sc,B(t_rx) = R_M(t_tag) + r − (v + V_M) δ (first order in δ ~ µs:
the neglected term is ~ a δ² < 1e-15 km), R_M, V_M Mars' SSB state. Differentiating the
light-time equation (dt_tx = dt_rx − dρ_g/c, dt_rx = −dδ), with u the unit vector from the
station to the spacecraft and k = 1/(1 − u·v_st,B/c):

    ∂ρ_g/∂r = k u,   ∂ρ_g/∂v = −δ k u,   ∂ρ_g/∂δ = −k u·(v + V_M − v_st,B).

Doppler over a count interval T ending at the time tag (the onboard receiver counts received
carrier cycles for T): the differenced range (ρ(t_tag) − ρ(t_tag − T))/T, i.e.

    ρ̇ = [ρ_g(end) − ρ_g(start)]/T + c (δ_end − δ_start)/T = Δρ_g/T + c (f − a T/2),

with f, a the clock frequency and drift at the end of the count. The start geometry uses the
state propagated back by T (its STM gives ∂(r, v)_start/∂x); the range bias cancels.

Not modelled (by the measurement simulation either): Shapiro delay, troposphere, ionosphere,
station delays.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import C_KM_S, GM_SUN, OMEGA_EARTH_RAD_S
from fsw.kernels import on_first_call
from fsw.models.environment import Environment

uplink_light_time = on_first_call(globals(), "uplink_light_time", "fsw.kernels.light_time")
uplink_reception = on_first_call(globals(), "uplink_reception", "fsw.kernels.light_time")
uplink_solution = on_first_call(globals(), "uplink_solution", "fsw.kernels.light_time")


@dataclass(frozen=True)
class UplinkGeometry:
    """Light-time solution of uplinks for N filters at K reception epochs: arrays (K, N, ...)."""

    rho: np.ndarray  # (K, N) geometric range c·τ, km
    d_rho_d_r: np.ndarray  # (K, N, 3) = k u
    d_rho_d_v: np.ndarray  # (K, N, 3) = −δ k u
    d_rho_d_delta: np.ndarray  # (K, N) km/s


def uplinks(env: Environment, station: str, t_tags: Iterable[float], r: np.ndarray, v: np.ndarray, delta: np.ndarray,
            iterations: int = 2) -> UplinkGeometry:
    """Solve the uplink light time at K time tags ``t_tags`` for spacecraft states r, v
    (K, N, 3) and clock phases δ (N,), all epochs in one batched iteration.

    Each epoch's station and Earth are expanded to second order about a reference transmit
    epoch t_g from the first filter's geocentric distance (|t_tx − t_g| ≤ R⊕/c + spread/c ≲
    0.05 s even for filters 1e4 km apart: expansion error < 1e-12 km). The fixed-point
    iteration τ ← |D(τ)|/c contracts by |u·v_station|/c ≈ 1e-4 per pass: two passes leave
    < 5e-10 s, i.e. the range good to < 2e-8 km (dρ/dτ ≈ 30 km/s; its noise is 1e-3 km, and the
    Doppler's 1e-7 km/s over 60 s is 6e-6 km).

    The arithmetic is two compiled kernels (:mod:`fsw.kernels.light_time`); t_g is rounded to
    the ~1e-7 s resolution of epochs near 6e8 s (Earth moves 3 mm in that), and every epoch's
    station is taken from the one grid node nearest the first t_g, so every filter uses one
    expansion.
    """
    tt = np.array([float(t) for t in t_tags])
    z = np.concatenate((np.asarray(r, dtype=float), np.asarray(v, dtype=float)), axis=2)
    rho, ku, d_rho_d_v, d_rho_d_delta = solve_uplinks(env, station, tt, z,
                                                      np.ascontiguousarray(delta, dtype=float), iterations)
    return UplinkGeometry(rho=rho, d_rho_d_r=ku, d_rho_d_v=d_rho_d_v, d_rho_d_delta=d_rho_d_delta)


class UplinkWork:
    """Arrays :func:`solve_uplinks` fills for K epochs and N filters, kept by a caller that solves
    the same shape for every measurement (its results are read before the next solution)."""

    # slotted: see fsw.executive.FrameExecutive
    __slots__ = ("r_sc", "v_mars", "t_g", "rho", "ku", "d_rho_d_v", "d_rho_d_delta")

    def __init__(self, K: int, N: int):
        self.r_sc = np.empty((K, N, 3))
        self.v_mars = np.empty((K, 3))
        self.t_g = np.empty(K)
        self.rho = np.empty((K, N))
        self.ku = np.empty((K, N, 3))
        self.d_rho_d_v = np.empty((K, N, 3))
        self.d_rho_d_delta = np.empty((K, N))


def solve_uplinks(env: Environment, station: str, tt: np.ndarray, z: np.ndarray, delta: np.ndarray,
                  iterations: int = 2, work: UplinkWork | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`uplinks` for the hot loop: time tags tt (K,), states z = [r, v] (K, N, 6) and δ (N,),
    all float64 and C-contiguous; returns (ρ, k u, −δ k u, ∂ρ/∂δ), in ``work``'s arrays if given."""
    K, N, _ = z.shape
    ts = tt.tolist()
    herm, t_first, step, lo_ok, hi_ok = env.hermite_window(min(ts) - 1.0, max(ts) + 1.0)
    w = work if work is not None else UplinkWork(K, N)
    r_sc, v_mars, t_g = w.r_sc, w.v_mars, w.t_g
    last = env.last_station_node(station)
    if last is not None:
        # usually the transmit epochs need neither another table nor another node: one call
        if uplink_solution(tt, z, delta, herm, t_first, step, lo_ok, hi_ok, last[0], last[1], OMEGA_EARTH_RAD_S,
                           GM_SUN, C_KM_S, iterations, r_sc, v_mars, t_g, w.rho, w.ku, w.d_rho_d_v,
                           w.d_rho_d_delta) == 0:
            return w.rho, w.ku, w.d_rho_d_v, w.d_rho_d_delta
    else:
        uplink_reception(tt, z, delta, herm, t_first, step, C_KM_S, r_sc, v_mars, t_g)
    herm, t_first, step, node, t_grid = transmit_tables(env, station, t_g)
    rho, ku, d_rho_d_v, d_rho_d_delta = w.rho, w.ku, w.d_rho_d_v, w.d_rho_d_delta
    uplink_light_time(tt, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, OMEGA_EARTH_RAD_S,
                      GM_SUN, C_KM_S, iterations, rho, ku, d_rho_d_v, d_rho_d_delta)
    return rho, ku, d_rho_d_v, d_rho_d_delta


def transmit_tables(env: Environment, station: str, t_g: np.ndarray) -> tuple[np.ndarray, float, float, np.ndarray, float]:
    """The Hermite table (nodes, first epoch, step) and the station's grid node (node, epoch) that
    serve the reference transmit epochs t_g (K,) of a light-time solution: the table covering them
    with the lookup's 1 s margin, the node nearest the first."""
    tg = t_g.tolist()
    herm, t_first, step = env.hermite_nodes(min(tg) - 1.0, max(tg) + 1.0)
    node, t_grid = env.station_node(station, tg[0])
    return herm, t_first, step, node, t_grid


def uplink(env: Environment, station: str, t_tag: float, r: np.ndarray, v: np.ndarray, delta: np.ndarray,
           iterations: int = 2) -> UplinkGeometry:
    """One reception epoch: r, v (N, 3); the result's arrays have the epoch axis dropped."""
    g = uplinks(env, station, (t_tag,), r[None], v[None], delta, iterations)
    return UplinkGeometry(g.rho[0], g.d_rho_d_r[0], g.d_rho_d_v[0], g.d_rho_d_delta[0])

"""One-way uplink range and Doppler as measured on board, with exact partials.

Geometry (seed 001 §4.1, one-way radiometric data with a DSAC-class onboard clock). A DSN
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

from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import C_KM_S, GM_SUN, OMEGA_EARTH_RAD_S
from fsw.models.environment import EARTH, MARS, SUN, Environment
from fsw.models.vector import cross


@dataclass(frozen=True)
class UplinkGeometry:
    """Light-time solution of one uplink for N filters."""

    rho: np.ndarray  # (N,) geometric range c·τ, km
    d_rho_d_r: np.ndarray  # (N, 3) = k u
    d_rho_d_v: np.ndarray  # (N, 3) = −δ k u
    d_rho_d_delta: np.ndarray  # (N,) km/s


def uplink(env: Environment, station: str, t_tag: float, r: np.ndarray, v: np.ndarray, delta: np.ndarray,
           iterations: int = 6) -> UplinkGeometry:
    """Solve the uplink light time for spacecraft states r, v (N, 3) at t_tag, clock phases δ (N,)."""
    pos, vel = env.states_ssb(t_tag)
    Rm, Vm = pos[MARS], vel[MARS]
    r_sc = Rm + r - (v + Vm) * delta[:, None]
    # Reference transmit epoch from the mean geometry; each filter's emitter position is a
    # second-order expansion about it (|Δt| ~ 0.1 s: error < 1e-7 km).
    tau_guess = float(np.linalg.norm(r_sc.mean(axis=0) - pos[EARTH])) / C_KM_S
    t_g = t_tag - tau_guess
    # t_g is rounded to the ~1e-7 s resolution of epochs near 6e8 s (Earth moves 3 mm in
    # that); offsets are taken from the stored t_g exactly so every filter uses one expansion
    tau_guess = t_tag - t_g
    pos_g, vel_g = env.states_ssb(t_g)
    s_pos, s_vel = env.station_gcrs(station, np.zeros(1), t_g)
    e_rel = pos_g[EARTH] - pos_g[SUN]
    a_earth = -GM_SUN * e_rel / float(e_rel @ e_rel) ** 1.5
    a_station = cross(np.array([0.0, 0.0, OMEGA_EARTH_RAD_S]), s_vel[0])
    R0 = pos_g[EARTH] + s_pos[0]
    V0 = vel_g[EARTH] + s_vel[0]
    A0 = a_earth + a_station
    tau = np.full(r.shape[0], tau_guess)
    for _ in range(iterations):
        dt = (tau_guess - tau - delta)[:, None]  # t_tx − t_g = (t_tag − δ − τ) − (t_tag − τ_g)
        D = r_sc - (R0 + V0 * dt + 0.5 * A0 * dt * dt)
        tau = np.linalg.norm(D, axis=-1) / C_KM_S
    dt = (tau_guess - tau - delta)[:, None]
    D = r_sc - (R0 + V0 * dt + 0.5 * A0 * dt * dt)
    rho = np.linalg.norm(D, axis=-1)
    u = D / rho[:, None]
    v_st = V0 + A0 * dt
    k = 1.0 / (1.0 - np.einsum("ni,ni->n", u, v_st) / C_KM_S)
    ku = k[:, None] * u
    return UplinkGeometry(
        rho=rho,
        d_rho_d_r=ku,
        d_rho_d_v=-delta[:, None] * ku,
        d_rho_d_delta=-np.einsum("ni,ni->n", ku, v + Vm - v_st),
    )

"""Compiled kernels: the one-way uplink light-time solution of :mod:`fsw.models.radiometric`.

Lubey & Ely 2022 §4.1 geometry, solved in the solar-system-barycentric frame for N filters at
K reception epochs (the model, its approximations and their sizes are stated in
:func:`fsw.models.radiometric.uplinks`):

* :func:`uplink_reception` — the spacecraft at reception r_sc,B = R_M(t_tag) + r − (v + V_M) δ
  and the reference transmit epoch t_g = t_tag − |r_sc,B − R_E(t_tag)|/c of the first filter;
* :func:`uplink_light_time` — the station and Earth expanded to second order about t_g, the
  fixed-point iteration τ ← |D(τ)|/c of c (t_rx − t_tx) = |r_sc,B(t_rx) − r_st,B(t_tx)|, and
  the partials ∂ρ/∂r = k u, ∂ρ/∂δ = −k u·(v + V_M − v_st), k = 1/(1 − u·v_st/c).

Planet states are the ephemeris table's cubic Hermite interpolant and its exact derivative
(:meth:`fsw.models.environment.Environment.states_many`), evaluated here; the station is the
Rodrigues rotation of its grid node about the celestial pole
(:meth:`fsw.models.environment.Environment.station_gcrs`). Every helper is in this module.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()

_SUN, _EARTH, _MARS = 0, 3, 4


@njit(cache=True)
def _planet_states(t, herm, t_first, step, pos, vel):
    """SSB positions and velocities (5, 3) at t from the Hermite nodes [p_i, h v_i, p_i+1, h v_i+1]
    of the grid interval holding t."""
    x = (t - t_first) / step
    i = int(x)
    s = x - i
    s2 = s * s
    s3 = s2 * s
    d0 = (6.0 * s2 - 6.0 * s) / step
    p0, p1, p2, p3 = 2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, 3.0 * s2 - 2.0 * s3, s3 - s2
    v0, v1, v2, v3 = d0, (3.0 * s2 - 4.0 * s + 1.0) / step, -d0, (3.0 * s2 - 2.0 * s) / step
    for b in range(5):
        for j in range(3):
            c = 3 * b + j
            pos[b, j] = p0 * herm[i, 0, c] + p1 * herm[i, 1, c] + p2 * herm[i, 2, c] + p3 * herm[i, 3, c]
            vel[b, j] = v0 * herm[i, 0, c] + v1 * herm[i, 1, c] + v2 * herm[i, 2, c] + v3 * herm[i, 3, c]


@njit("void(float64[::1], float64[:, :, ::1], float64[::1], float64[:, :, ::1], float64, "
      "float64, float64, float64[:, :, ::1], float64[:, ::1], float64[::1])", cache=True)
def uplink_reception(t_tags, z, delta, herm, t_first, step, c_km_s, r_sc, v_mars, t_g):
    """r_sc (K, N, 3) the spacecraft at reception (SSB), v_mars (K, 3) Mars' SSB velocity and
    t_g (K,) the reference transmit epochs, for states z = [r, v] (K, N, 6) at the time tags and
    clock phases δ (N,)."""
    K, N, _ = z.shape
    pos = np.empty((5, 3))
    vel = np.empty((5, 3))
    for k in range(K):
        _planet_states(t_tags[k], herm, t_first, step, pos, vel)
        for j in range(3):
            v_mars[k, j] = vel[_MARS, j]
        for i in range(N):
            for j in range(3):
                r_sc[k, i, j] = pos[_MARS, j] + z[k, i, j] - (z[k, i, 3 + j] + vel[_MARS, j]) * delta[i]
        g2 = 0.0
        for j in range(3):
            g = r_sc[k, 0, j] - pos[_EARTH, j]
            g2 += g * g
        t_g[k] = t_tags[k] - math.sqrt(g2) / c_km_s


@njit("void(float64[::1], float64[::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, ::1], float64[::1], "
      "float64[:, :, ::1], float64, float64, float64[:, ::1], float64, float64, float64, float64, int64, "
      "float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, ::1])", cache=True)
def uplink_light_time(t_tags, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun,
                      c_km_s, iterations, rho, ku, d_rho_d_v, d_rho_d_delta):
    """ρ (K, N), ∂ρ/∂r = k u, ∂ρ/∂v = −δ k u (K, N, 3) and ∂ρ/∂δ (K, N) of the uplinks whose reception is r_sc (K, N, 3)
    with reference transmit epochs t_g (K,), for states z = [r, v] (K, N, 6); ``node`` (4, 3) is the station's grid node
    [r0, k × r0, k (k·r0), dv] at t_grid (Rodrigues: r(Δt) = r0 cos θ + (k × r0) sin θ
    + k (k·r0)(1 − cos θ) + dv Δt, θ = ω Δt, and its exact rate)."""
    K, N, _ = r_sc.shape
    pos = np.empty((5, 3))
    vel = np.empty((5, 3))
    rel = np.empty(3)
    V0 = np.empty(3)
    A0 = np.empty(3)
    s_pos = np.empty(3)
    s_vel = np.empty(3)
    D = np.empty(3)
    for k in range(K):
        _planet_states(t_g[k], herm, t_first, step, pos, vel)
        dt_s = (t_g[0] - t_grid) + (t_g[k] - t_g[0])
        theta = omega * dt_s
        c = math.cos(theta)
        s = math.sin(theta)
        for j in range(3):
            s_pos[j] = node[0, j] * c + node[1, j] * s + node[2, j] * (1.0 - c) + node[3, j] * dt_s
            s_vel[j] = omega * (node[1, j] * c + (node[2, j] - node[0, j]) * s) + node[3, j]
        e2 = 0.0
        for j in range(3):
            e = pos[_EARTH, j] - pos[_SUN, j]
            e2 += e * e
        f = -gm_sun / (e2 * math.sqrt(e2))
        for j in range(3):
            A0[j] = f * (pos[_EARTH, j] - pos[_SUN, j])
        A0[0] -= omega * s_vel[1]  # + ω ẑ × v_station (rotation's centripetal term)
        A0[1] += omega * s_vel[0]
        for j in range(3):
            A0[j] *= 0.5
            V0[j] = vel[_EARTH, j] + s_vel[j]
        tau_g = t_tags[k] - t_g[k]
        for i in range(N):
            for j in range(3):
                rel[j] = r_sc[k, i, j] - (pos[_EARTH, j] + s_pos[j])  # spacecraft from the station at t_g
            base = tau_g - delta[i]  # t_tx − t_g = base − τ
            dt = base - tau_g
            for _ in range(iterations):
                d2 = 0.0
                for j in range(3):
                    D[j] = rel[j] - dt * (V0[j] + A0[j] * dt)
                    d2 += D[j] * D[j]
                dt = base - math.sqrt(d2) / c_km_s
            d2 = 0.0
            for j in range(3):
                D[j] = rel[j] - dt * (V0[j] + A0[j] * dt)
                d2 += D[j] * D[j]
            rr = math.sqrt(d2)
            uv = 0.0
            for j in range(3):
                uv += D[j] / rr * (V0[j] + (2.0 * A0[j]) * dt)
            kk = 1.0 / (1.0 - uv / c_km_s)
            dd = 0.0
            for j in range(3):
                kuj = kk * (D[j] / rr)
                ku[k, i, j] = kuj
                d_rho_d_v[k, i, j] = -delta[i] * kuj
                dd += kuj * (z[k, i, 3 + j] + v_mars[k, j] - (V0[j] + (2.0 * A0[j]) * dt))
            rho[k, i] = rr
            d_rho_d_delta[k, i] = -dd


@njit("int64(float64[::1], float64[:, :, ::1], float64[::1], float64[:, :, ::1], float64, float64, float64, float64, "
      "float64[:, ::1], float64, float64, float64, float64, int64, float64[:, :, ::1], float64[:, ::1], float64[::1], "
      "float64[:, ::1], float64[:, :, ::1], float64[:, :, ::1], float64[:, ::1])", cache=True)
def uplink_solution(t_tags, z, delta, herm, t_first, step, lo_ok, hi_ok, node, t_grid, omega, gm_sun, c_km_s,
                    iterations, r_sc, v_mars, t_g, rho, ku, d_rho_d_v, d_rho_d_delta):
    """:func:`uplink_reception` then :func:`uplink_light_time` in one call, when the transmit epochs
    t_g lie where the caller's table and station node serve: the table's interior [lo_ok, hi_ok]
    (with the 1 s margin the table lookup asks for) and within 300 s less 1 ms of the node's epoch
    t_grid (the node nearest t_g[0]; the 1 ms keeps clear of a tie). Returns 1 with only the
    reception solved otherwise (the caller looks up table and node for t_g and finishes)."""
    uplink_reception(t_tags, z, delta, herm, t_first, step, c_km_s, r_sc, v_mars, t_g)
    lo = t_g[0]
    hi = t_g[0]
    for k in range(1, t_g.shape[0]):
        lo = min(lo, t_g[k])
        hi = max(hi, t_g[k])
    if lo - 1.0 < lo_ok or hi + 1.0 > hi_ok or abs(t_g[0] - t_grid) >= 299.999:
        return 1
    uplink_light_time(t_tags, t_g, r_sc, z, v_mars, delta, herm, t_first, step, node, t_grid, omega, gm_sun, c_km_s,
                      iterations, rho, ku, d_rho_d_v, d_rho_d_delta)
    return 0

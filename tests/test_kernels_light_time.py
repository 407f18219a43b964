"""The compiled light-time kernels against the numpy solution they replaced
(tests/reference_radiometric.py), and the prefetched station nodes against one-node evaluation."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.astro.constants import C_KM_S, GM_SUN, OMEGA_EARTH_RAD_S
from fsw.astro.earth import itrs_to_gcrs_matrix
from fsw.astro.stations import station_state_icrf
from fsw.models.environment import Environment
from fsw.kernels.light_time import uplink_solution
from fsw.models.radiometric import UplinkWork, solve_uplinks, uplinks
from reference_radiometric import reference_uplinks

ENV = Environment()
T0 = 5.98e8  # 2018-12, inside the uploaded Earth orientation


@pytest.mark.parametrize("seed", range(6))
def test_light_time_kernels_match_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    K = 1 + seed % 2
    N = 1 + seed % 4
    t = T0 + rng.uniform(0.0, 30 * 86400.0)
    t_tags = (t, t - 60.0)[:K]
    mars_to_earth = ENV.positions_ssb(t)[3] - ENV.positions_ssb(t)[4]
    # near Mars, spread like the filters of a bank
    r = rng.normal(0.0, 5e4, (K, N, 3)) + 1e3 * rng.normal(size=(1, 1, 3)) + 0.0 * mars_to_earth
    v = rng.normal(0.0, 5.0, (K, N, 3))
    delta = rng.normal(0.0, 1e-6, N)
    station = ("DSS-14", "DSS-43", "DSS-63")[seed % 3]
    g = uplinks(ENV, station, t_tags, r, v, delta)
    ref = reference_uplinks(ENV, station, t_tags, r, v, delta)
    assert np.max(np.abs(g.rho - ref.rho) / ref.rho) < 1e-15
    assert np.max(np.abs(g.d_rho_d_r - ref.d_rho_d_r)) < 1e-14
    assert np.max(np.abs(g.d_rho_d_v - ref.d_rho_d_v)) < 1e-19
    assert np.max(np.abs(g.d_rho_d_delta - ref.d_rho_d_delta) / np.abs(ref.d_rho_d_delta)) < 1e-12


def test_prefetched_station_nodes_equal_one_node_evaluation():
    env = Environment()
    t_grid = 600.0 * round(T0 / 600.0)
    env.station_node("DSS-43", t_grid)  # one miss fills the next nodes
    for j in range(24):
        tj = t_grid + 600.0 * j
        node, t_node = env.station_node("DSS-43", tj + 100.0)
        assert t_node == tj
        r0, v0 = station_state_icrf("DSS-43", tj)
        k = itrs_to_gcrs_matrix(tj)[:, 2]
        kxr = np.cross(k, r0)
        expect = np.stack([r0, kxr, k * (k @ r0), v0 - OMEGA_EARTH_RAD_S * kxr])
        scale = np.array([[6400.0], [6400.0], [6400.0], [1e-6]])
        assert np.max(np.abs(node - expect) / scale) < 1e-13


def test_one_call_solution_equals_two_calls_and_hands_back_a_wrong_node():
    rng = np.random.default_rng(7)
    env = Environment()
    N = 3
    t = T0 + 5 * 86400.0
    tt = np.array([t, t - 60.0])
    z = np.concatenate((rng.normal(0.0, 5e4, (2, N, 3)), rng.normal(0.0, 5.0, (2, N, 3))), axis=2)
    delta = rng.normal(0.0, 1e-6, N)
    two = [np.array(a) for a in solve_uplinks(env, "DSS-63", tt, z, delta)]  # no node yet: two calls
    assert env.last_station_node("DSS-63") is not None and env.last_station_node("DSS-14") is None
    one = solve_uplinks(env, "DSS-63", tt, z, delta)  # the node just used: one call
    for a, b in zip(one, two):
        assert np.array_equal(a, b)
    herm, t_first, step, lo_ok, hi_ok = env.hermite_window(t - 61.0, t + 1.0)
    node, t_grid = env.last_station_node("DSS-63")
    w = UplinkWork(2, N)
    args = (OMEGA_EARTH_RAD_S, GM_SUN, C_KM_S, 2, w.r_sc, w.v_mars, w.t_g, w.rho, w.ku, w.d_rho_d_v, w.d_rho_d_delta)
    assert uplink_solution(tt, z, delta, herm, t_first, step, lo_ok, hi_ok, node, t_grid, *args) == 0
    assert np.array_equal(w.rho, two[0])
    # a node ten minutes off, or transmit epochs outside the table's interior: the caller finishes
    assert uplink_solution(tt, z, delta, herm, t_first, step, lo_ok, hi_ok, node, t_grid + 600.0, *args) == 1
    assert uplink_solution(tt, z, delta, herm, t_first, step, lo_ok, float(w.t_g.min()), node, t_grid, *args) == 1

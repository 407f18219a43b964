"""The compiled light-time kernels against the numpy solution they replaced
(tests/reference_radiometric.py), and the prefetched station nodes against one-node evaluation."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.astro.constants import OMEGA_EARTH_RAD_S
from fsw.astro.earth import itrs_to_gcrs_matrix
from fsw.astro.stations import station_state_icrf
from fsw.models.environment import Environment
from fsw.models.radiometric import uplinks
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

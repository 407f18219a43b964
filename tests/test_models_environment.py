"""The onboard environment as a checkpoint carries it: small, and restored to the same bits."""

from __future__ import annotations

import copy
import pickle

import numpy as np

from fsw.models.environment import Environment

T0 = 6.0e8  # TDB s, late 2018 (inside DE421)


def _used() -> Environment:
    env = Environment()
    env.states_many((T0, T0 + 3600.0))
    for k in range(40):  # a pass: several prefetches of station nodes, some evicted
        env.station_node("DSS-14" if k % 2 else "DSS-63", T0 + 9000.0 * k)
    return env


def test_a_pickled_environment_leaves_its_tables_out_and_rebuilds_them_to_the_same_bits():
    env = _used()
    data = pickle.dumps(env, protocol=pickle.HIGHEST_PROTOCOL)
    # the table alone is > 2 MB (60 days at 1800 s, 5 bodies, positions, velocities, Hermite nodes)
    assert env._hermite.nbytes + sum(a.nbytes for a in env._table.nodes) > 2_000_000
    assert len(data) < 150_000
    back = pickle.loads(data)
    assert np.array_equal(back._hermite, env._hermite)
    assert (back._table.t_first, back._table.t_last, back._table.step) == (env._table.t_first, env._table.t_last,
                                                                           env._table.step)
    for a, b in zip(back._table.nodes, env._table.nodes):
        assert np.array_equal(a, b)
    # the station cache: same keys in the same (eviction) order, same node values
    assert list(back._stations) == list(env._stations)
    for key, node in env._station_arrays.items():
        assert np.array_equal(back._station_arrays[key], node)
        assert all(np.array_equal(x, y) for x, y in zip(back._stations[key], env._stations[key]))
    # and both answer every later lookup alike, including one that extends the table
    for t in (T0 + 7200.0, T0 + 80 * 86400.0):
        for (p, v), (q, w) in [(env.states_many((t,)), back.states_many((t,)))]:
            assert np.array_equal(p, q) and np.array_equal(v, w)
        n1, g1 = env.station_node("DSS-14", t)
        n2, g2 = back.station_node("DSS-14", t)
        assert g1 == g2 and np.array_equal(n1, n2)


def test_an_unused_environment_round_trips():
    back = pickle.loads(pickle.dumps(Environment()))
    assert back._table is None and not back._stations
    p, _ = back.states_many((T0,))
    assert np.all(np.isfinite(p))


def test_a_copy_in_memory_copies_the_table_instead_of_rebuilding_it():
    env = _used()
    twin = copy.deepcopy(env)
    assert twin._table is not env._table and twin._hermite is not env._hermite
    assert np.array_equal(twin._hermite, env._hermite)
    assert list(twin._stations) == list(env._stations)

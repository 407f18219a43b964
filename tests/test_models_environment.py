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


def test_a_copy_in_memory_shares_what_is_never_written_and_keeps_its_own_caches():
    env = _used()
    twin = copy.deepcopy(env)
    # the table, its Hermite nodes and the station nodes are shared, not copied or rebuilt
    assert twin._table is env._table and twin._hermite is env._hermite
    assert list(twin._stations) == list(env._stations)
    assert all(twin._station_arrays[k] is node for k, node in env._station_arrays.items())
    # the caches are the copy's own: what it adds and evicts leaves the original as it was
    assert twin._stations is not env._stations and twin._station_arrays is not env._station_arrays
    before = list(env._stations)
    for k in range(40):
        twin.station_node("DSS-43", T0 + 50 * 86400.0 + 9000.0 * k)
    assert list(env._stations) == before and list(twin._stations) != before
    assert twin.last_station_node("DSS-43") is not None and env.last_station_node("DSS-43") is None
    # a lookup past the table makes the copy a table of its own
    twin.states_many((T0 + 80 * 86400.0,))
    assert twin._table is not env._table and env._table.t_last < T0 + 80 * 86400.0


def test_the_shared_nodes_are_never_written_by_the_filters():
    """What a copy shares must stay as it was made. A bank and a copy of it fly the golden
    recording's four days; then every station node either environment holds is made again by a
    fresh environment (a node is a function of station and epoch alone) and compared bit for bit,
    and so is the table."""
    from pathlib import Path

    from fsw.filters.bank import FilterBank
    from fsw.filters.errors import MeasurementRejected
    from ground.mcap_io.reader import read_messages
    from tools.scenario import load_scenario, resolve

    golden = Path(__file__).parent / "golden" / "insight-4day.mcap"
    meas = [r.message for r in read_messages(golden, topics=["/sim/measurements"])]
    fsw = resolve(load_scenario(str(golden.with_suffix(".yaml"))))[0].fsw
    state = fsw.initial_state
    bank = FilterBank(fsw.bank, state.t_s, state.position_km, state.velocity_km_s)
    half = len(meas) // 2
    flown = 0
    for m in meas[:half]:
        try:
            bank.process(m)
            flown += 1
        except MeasurementRejected:
            pass
    copied = copy.deepcopy(bank)
    twin = pickle.loads(pickle.dumps(bank))  # rebuilt from its checkpoint form: shares nothing
    for m in meas[half:]:
        for b in (bank, copied, twin):
            try:
                b.process(m)
                flown += b is bank
            except MeasurementRejected:
                pass
    assert flown == len(meas)
    fresh = Environment()
    for env in (bank.stack.env, copied.stack.env):
        assert len(env._station_arrays) > 100
        for (name, t_grid), node in env._station_arrays.items():
            again, _ = fresh.station_node(name, t_grid)
            assert np.array_equal(node, again), (name, t_grid)
            assert all(np.array_equal(a, b) for a, b in zip(env._stations[(name, t_grid)], again))
        rebuilt = Environment()
        tab = rebuilt._build_table(*env._table_span)
        assert np.array_equal(env._hermite, rebuilt._hermite)
        assert all(np.array_equal(a, b) for a, b in zip(env._table.nodes, tab.nodes))
    # and the copy that shared them came to the same bits as the one that shares nothing
    assert np.array_equal(copied.stack.x, twin.stack.x) and np.array_equal(copied.stack.P, twin.stack.P)
    assert np.array_equal(bank.stack.x, twin.stack.x) and np.array_equal(bank.stack.P, twin.stack.P)

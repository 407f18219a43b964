"""The interface every gating network shares (registry, parameters, weights, disabled filters)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from fsw.filters.record import BankRecord
from fsw.gating import (
    NETWORKS,
    GatingInputError,
    InvalidParameterError,
    UnknownNetworkError,
    UnknownParameterError,
    make_network,
    params_type,
)
from fsw.gating.base import apply_lower_bound, reenter_probabilities
from fsw.interface import typed

NAMES = ("radio", "optical", "fused", "radio-Q")
SMALL = {
    "chi2": {"batch_size": 5},
    "chi2-two-sided": {"batch_size": 5},
    "residual-correlation": {"window": 8, "frequencies": (0.1,)},
    "hierarchical": {"groups": {"plain": ("radio", "optical", "fused"), "high-Q": ("radio-Q",)}},
}


def records(count, seed=0, active=None):
    rng = np.random.default_rng(seed)
    out = []
    for k in range(count):
        S = np.tile(np.eye(2), (4, 1, 1)) * np.array([1.0, 2.0, 0.5, 4.0])[:, None, None]
        res = rng.standard_normal((4, 2))
        chi2 = np.einsum("ij,ij->i", res, np.linalg.solve(S, res[..., None])[..., 0])
        out.append(BankRecord(t=100.0 + k, seq=k, kind="optical", filters=NAMES, residual=res, S=S, chi2=chi2,
                              processed=np.array([False, True, True, False]), active=active))
    return out


def test_registry_names():
    assert set(NETWORKS) == {"chi2", "magill", "moe", "hierarchical", "residual-correlation", "chi2-two-sided"}
    with pytest.raises(UnknownNetworkError):
        make_network("kalman-magic", NAMES)
    with pytest.raises(UnknownNetworkError):
        params_type("nope")


@pytest.mark.parametrize("name", sorted(NETWORKS))
def test_params_are_documented_frozen_specs(name):
    cls = params_type(name)
    assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen
    for f in dataclasses.fields(cls):
        assert f.metadata.get("doc"), f"{name}.{f.name} has no doc"
    schema = typed.json_schema(cls)
    assert schema["additionalProperties"] is False
    defaults = cls()
    assert typed.decode(cls, typed.encode(defaults)) == defaults


@pytest.mark.parametrize("name", sorted(NETWORKS))
def test_weights_sum_to_one_and_disabled_filters_get_zero(name):
    active = np.array([True, False, True, True])
    net = make_network(name, NAMES, SMALL.get(name))
    # A-priori weights: equal, or for the two-level network equal per level (1/2 per bank).
    prior = [1 / 6, 1 / 6, 1 / 6, 1 / 2] if name == "hierarchical" else [0.25] * 4
    np.testing.assert_allclose(net.weights, prior)
    updates = [u for r in records(40, active=active) if (u := net.update(r))]
    assert updates, "no weights produced"
    for u in updates:
        assert u.weights[1] == 0.0
        assert u.weights.sum() == pytest.approx(1.0, abs=1e-12)
        assert np.all(u.weights >= 0.0)
        assert u.filters == NAMES and u.network == name
        json.dumps(u.as_dict())
    # Re-enabled: back in with a positive weight.
    after = [u for r in records(10, seed=1) if (u := net.update(r))]
    assert net.weights[1] > 0.0 and net.weights.sum() == pytest.approx(1.0)
    st = net.state_dict()
    json.dumps(st)
    assert st["network"] == name and st["active"] == [True] * 4
    net.reset()
    np.testing.assert_allclose(net.weights, prior)
    assert after is not None


@pytest.mark.parametrize("name", sorted(NETWORKS))
def test_bad_input_and_parameters_are_typed_errors(name):
    net = make_network(name, NAMES, SMALL.get(name))
    good = records(1)[0]
    bad = dataclasses.replace(good, chi2=np.array([1.0, np.nan, 1.0, 1.0]))
    with pytest.raises(GatingInputError):
        net.update(bad)
    with pytest.raises(GatingInputError):
        net.update(dataclasses.replace(good, S=np.ones((4, 3, 3))))
    with pytest.raises(GatingInputError):
        net.update(dataclasses.replace(good, filters=("a", "b", "c", "d")))
    with pytest.raises(GatingInputError):
        net.update(dataclasses.replace(good, active=np.zeros(4, bool)))
    assert net.state_dict()["rejected"] == 4
    with pytest.raises(UnknownParameterError):
        net.set_param("no_such_parameter", 1.0)
    first = dataclasses.fields(params_type(name))[0].name
    with pytest.raises(InvalidParameterError):
        net.set_param(first, "not a number")
    with pytest.raises(InvalidParameterError):
        make_network(name, NAMES, {"no_such_parameter": 1})
    with pytest.raises(InvalidParameterError):
        make_network(name, NAMES, object())


def test_lower_bound_and_reentry_helpers():
    mask = np.ones(4, bool)
    logp = np.log(np.array([0.9985, 0.0010, 0.0004, 0.0001]))
    p = np.exp(apply_lower_bound(logp, mask, 1e-3))
    assert p.sum() == pytest.approx(1.0) and p.min() >= 1e-3 - 1e-15
    assert p[1] == pytest.approx(1e-3) and p[0] == pytest.approx(0.997)
    q = reenter_probabilities(np.array([0.6, 0.0, 0.4, 0.0]), np.array([1, 0, 1, 0], bool), mask)
    np.testing.assert_allclose(q, [0.3, 0.25, 0.2, 0.25])

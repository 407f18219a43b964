"""Gating networks by name: the names configuration files and telecommands use."""

from __future__ import annotations

from typing import Any, Sequence

from fsw.gating.base import GatingError, GatingNetwork
from fsw.gating.chi2 import Chi2Network
from fsw.gating.chi2_two_sided import Chi2TwoSidedNetwork
from fsw.gating.hierarchical import HierarchicalNetwork
from fsw.gating.magill import MagillNetwork
from fsw.gating.moe import MoeNetwork
from fsw.gating.residual_correlation import ResidualCorrelationNetwork

NETWORKS: dict[str, type[GatingNetwork]] = {
    cls.name: cls
    for cls in (
        Chi2Network,
        MagillNetwork,
        MoeNetwork,
        HierarchicalNetwork,
        ResidualCorrelationNetwork,
        Chi2TwoSidedNetwork,
    )
}


class UnknownNetworkError(GatingError):
    """A gating network name that is not in the registry."""


def params_type(name: str) -> type:
    """The config dataclass of network ``name``."""
    if name not in NETWORKS:
        raise UnknownNetworkError(f"unknown gating network {name!r}; known: {', '.join(NETWORKS)}")
    return NETWORKS[name].params_type


def make_network(name: str, filter_names: Sequence[str], params: Any = None) -> GatingNetwork:
    """Build network ``name`` over the bank ``filter_names``; ``params`` is its config dataclass,
    a mapping decoded into it, or None for the documented defaults."""
    if name not in NETWORKS:
        raise UnknownNetworkError(f"unknown gating network {name!r}; known: {', '.join(NETWORKS)}")
    return NETWORKS[name](filter_names, params)

"""Gating networks: turn the filter bank's residual records into filter weights.

One module per network (see DESIGN.md): ``chi2`` and ``chi2-two-sided`` (batch, Lubey & Ely 2022 eqs. 5–8
and its two-sided fix), ``magill`` (Lubey & Ely 2022 eqs. 1–4 in the log domain), ``moe`` (Chaer et al. 1997
eqs. 11–20), ``hierarchical`` (Chaer et al. 1998 eqs. 2–16) and ``residual-correlation`` (Hanlon & Maybeck 2000
eqs. 18–22). Build them with :func:`make_network`.
"""

from fsw.gating.base import (
    GatingError,
    GatingInputError,
    GatingNetwork,
    InvalidParameterError,
    UnknownParameterError,
    WeightsUpdate,
)
from fsw.gating.registry import NETWORKS, UnknownNetworkError, make_network, params_type

__all__ = [
    "GatingError",
    "GatingInputError",
    "GatingNetwork",
    "InvalidParameterError",
    "NETWORKS",
    "UnknownNetworkError",
    "UnknownParameterError",
    "WeightsUpdate",
    "make_network",
    "params_type",
]

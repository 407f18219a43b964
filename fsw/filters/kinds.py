"""The registry of onboard measurement models: which ICD kinds the EKF bank can process.

A kind is declared once, in the ICD (:mod:`fsw.interface.kinds`); its onboard model
(:class:`fsw.filters.kind_model.KindModel`) is registered here. Every kind list of the filters
— the kinds a filter may process, the per-kind noise scales, the dimensions screened — is
derived from this registry.
"""

from __future__ import annotations

from collections.abc import Mapping

from fsw.filters.kind_model import KindModel
from fsw.filters.optical_kind import OpticalModel
from fsw.filters.radiometric_kinds import DopplerModel, RangeModel
from fsw.filters.tracking_kinds import MODELS as TRACKING_MODELS, TrackingKindModel
from fsw.interface import kinds


def _register(*models: KindModel) -> dict[str, KindModel]:
    out: dict[str, KindModel] = {}
    for model in models:
        name = model.declaration.name
        if kinds.BY_NAME.get(name) != model.declaration:
            raise ValueError(f"kind {name!r} is not declared in the ICD as its model says")
        if name in out:
            raise ValueError(f"kind {name!r} registered twice")
        out[name] = model
    # ICD order, whatever the registration order
    return {k: out[k] for k in kinds.NAMES if k in out}


#: Kind name -> its onboard model, in ICD order.
REGISTRY: Mapping[str, KindModel] = _register(RangeModel(), DopplerModel(), OpticalModel())

#: The kinds the EKF bank has models for.
FILTER_KINDS: tuple[str, ...] = tuple(REGISTRY)

#: Expected number of components of each kind the bank processes.
DIMENSIONS: Mapping[str, int | None] = {k: m.declaration.dimension for k, m in REGISTRY.items()}


def _register_tracking(*models: TrackingKindModel) -> dict[str, TrackingKindModel]:
    out: dict[str, TrackingKindModel] = {}
    for model in models:
        name = model.declaration.name
        if kinds.BY_NAME.get(name) != model.declaration:
            raise ValueError(f"kind {name!r} is not declared in the ICD as its model says")
        if name in out or name in REGISTRY:
            raise ValueError(f"kind {name!r} registered twice")
        out[name] = model
    return {k: out[k] for k in kinds.NAMES if k in out}


#: Kind name -> its onboard model in the Earth-orbit bank (:mod:`fsw.filters.orbit_bank`, ground-station
#: tracking after injection), in ICD order. The Mars bank above has no model for these kinds.
ORBIT_REGISTRY: Mapping[str, TrackingKindModel] = _register_tracking(*TRACKING_MODELS)

#: The kinds the Earth-orbit bank has models for.
ORBIT_KINDS: tuple[str, ...] = tuple(ORBIT_REGISTRY)


def model(kind: str) -> KindModel:
    """The onboard model of ``kind`` (KeyError if the bank has none)."""
    try:
        return REGISTRY[kind]
    except KeyError:
        raise KeyError(f"no onboard model for measurement kind {kind!r}; known: {', '.join(FILTER_KINDS)}") from None


def of_family(family: str) -> tuple[str, ...]:
    """The kinds of a measurement family (e.g. ``radio``: range and Doppler), in ICD order."""
    return tuple(k for k, m in REGISTRY.items() if m.family == family)

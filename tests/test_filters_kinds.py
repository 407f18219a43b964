"""Measurement kinds: declared once in the ICD, every kind list derived, one model per kind."""

from __future__ import annotations

import dataclasses
import typing

import pytest

from fsw.config import FswConfig
from fsw.filters import kinds as registry
from fsw.filters.config import FilterConfig
from fsw.filters.presets import FUSED, OPTICAL, RADIO, nominal_bank
from fsw.interface import codec, kinds, messages
from fsw.interface.messages import Measurement, Stamp


def test_the_icd_enumerates_exactly_the_declared_kinds():
    assert typing.get_args(messages.MeasurementKind) == kinds.NAMES
    assert messages.MEASUREMENT_KINDS == kinds.NAMES
    assert messages.MEASUREMENT_DIMENSION == {k.name: k.dimension for k in kinds.DECLARED}
    assert codec.schema_of(Measurement)["properties"]["kind"]["enum"] == list(kinds.NAMES)
    assert len(set(kinds.NAMES)) == len(kinds.DECLARED)


def test_a_kind_outside_the_declaration_is_refused_by_the_decoder():
    good = codec.to_dict(Measurement(seq=0, t_s=0.0, timestamp=Stamp(0, 0), kind="range", source="DSS-14",
                                     value=(1.0,), sigma=(1.0,)))
    with pytest.raises(codec.ICDError, match="kind"):
        codec.from_dict(Measurement, {**good, "kind": "lidar"})


def test_declared_dimensions_and_required_fields_are_enforced_by_the_icd():
    base = dict(seq=0, t_s=0.0, timestamp=Stamp(0, 0), source="phobos", sigma=(1.0, 1.0))
    with pytest.raises(ValueError, match="needs attitude_q"):
        Measurement(kind="optical", value=(1.0, 2.0), **base)
    with pytest.raises(ValueError, match="2 component"):
        Measurement(kind="optical", value=(1.0,), attitude_q=(1.0, 0.0, 0.0, 0.0), **{**base, "sigma": (1.0,)})
    # a kind of free dimension takes any length
    Measurement(kind="generic-linear", value=(1.0, 2.0, 3.0), **{**base, "sigma": (1.0, 1.0, 1.0)})


def test_the_registry_models_declared_kinds_in_icd_order():
    assert registry.FILTER_KINDS == ("range", "doppler", "optical")
    for name, model in registry.REGISTRY.items():
        assert model.declaration is kinds.declaration(name)
        assert registry.DIMENSIONS[name] == kinds.declaration(name).dimension
    with pytest.raises(KeyError, match="no onboard model"):
        registry.model("generic-linear")


def test_a_model_must_match_the_icd_declaration():
    @dataclasses.dataclass
    class Undeclared:
        declaration: kinds.KindDeclaration
        family: str = "radio"

    with pytest.raises(ValueError, match="not declared"):
        registry._register(Undeclared(kinds.KindDeclaration("lidar", 1, "km", "laser range")))
    with pytest.raises(ValueError, match="twice"):
        registry._register(*(registry.REGISTRY["range"],) * 2)


def test_kind_lists_of_the_filters_derive_from_the_registry():
    assert RADIO == registry.of_family("radio") == ("range", "doppler")
    assert OPTICAL == registry.of_family("optical") == ("optical",)
    assert FUSED == registry.FILTER_KINDS
    assert FilterConfig(name="f").processes == registry.FILTER_KINDS
    with pytest.raises(ValueError, match="unknown measurement kinds"):
        FilterConfig(name="f", processes=("generic-linear",))


def test_filter_families_follow_the_kinds_each_filter_processes():
    fams = {f.name: f.families for f in FswConfig(bank=nominal_bank()).families()}
    assert fams == {"radio": ("radio",), "optical": ("optical",), "fused": ("radio", "optical")}

"""The onboard models of ground-station tracking kinds for the Earth-orbit bank
(:mod:`fsw.filters.orbit_bank`): which component of the topocentric prediction
(:func:`fsw.models.topocentric.predict`) each ICD kind is, and whether its residual is an angle
to wrap. Registered in :data:`fsw.filters.kinds.ORBIT_REGISTRY`, through which the Earth-orbit
bank screens and predicts.
"""

from __future__ import annotations

from dataclasses import dataclass

from fsw.interface import kinds
from fsw.interface.kinds import KindDeclaration
from fsw.models import topocentric


@dataclass(frozen=True)
class TrackingKindModel:
    """One ground-station kind: its ICD declaration and where the topocentric model gives it."""

    declaration: KindDeclaration
    wrap: bool = False  # residual is an angle modulo 2π (azimuth)

    @property
    def component(self) -> int:
        return topocentric.COMPONENTS.index(self.declaration.name)


MODELS: tuple[TrackingKindModel, ...] = (
    TrackingKindModel(kinds.STATION_RANGE),
    TrackingKindModel(kinds.STATION_RANGE_RATE),
    TrackingKindModel(kinds.AZIMUTH, wrap=True),
    TrackingKindModel(kinds.ELEVATION),
)

"""The measurement kinds of the ICD, declared once.

Every list of kinds in navbank — the values ``Measurement.kind`` may take, their dimensions,
the kinds the onboard filters have models for — is derived from :data:`DECLARED` below. Adding a
kind means declaring it here and registering its onboard model
(:mod:`fsw.filters.kinds`); nothing else enumerates kinds.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class KindDeclaration:
    """One measurement kind as the ICD defines it.

    ``dimension`` is the number of components of ``Measurement.value`` (None: any, fixed by the
    scenario); ``requires`` names optional ``Measurement`` fields a measurement of this kind
    must carry.
    """

    name: str
    dimension: int | None
    unit: str
    doc: str
    requires: tuple[str, ...] = ()


RANGE = KindDeclaration(
    "range", 1, "km", "one-way uplink pseudo-range from a DSN station, received on board")
DOPPLER = KindDeclaration(
    "doppler", 1, "km/s",
    "one-way uplink Doppler as a range-rate over the count interval count_time_s ending at t_s "
    "(in frequency, f_D = -(DOPPLER_CARRIER_HZ / c) x range rate: fsw.astro.constants.MHZ_TO_KM_S)")

#: DSN X-band carriers (DSN Telecommunications Link Design Handbook 810-005, module 201: uplink
#: 7145-7190 MHz, downlink 8400-8450 MHz). navbank's Doppler is one-way *uplink* — the station
#: transmits, the spacecraft counts the received carrier against its own clock — so the carrier
#: that converts a Doppler shift to a range rate is the uplink one.
X_UPLINK_HZ: float = 7.15e9
X_DOWNLINK_HZ: float = 8.4e9
DOPPLER_CARRIER_HZ: float = X_UPLINK_HZ
OPTICAL = KindDeclaration(
    "optical", 2, "px", "[sample, line] of a target centre in the navigation camera image",
    requires=("attitude_q",))
GENERIC_LINEAR = KindDeclaration(
    "generic-linear", None, "units of the linear scenario", "z = H x + v of a linear scenario")

# Ground-station tracking of an Earth orbiter (the leo-injection measurements of Garhwal, Halder &
# Sinha): the station named by ``source`` sees the spacecraft; geometry at the time tag
# (light time, ~2 ms at LEO distances, left out on both sides).
STATION_RANGE = KindDeclaration(
    "station-range", 1, "km", "two-way range from a ground station to an Earth orbiter")
STATION_RANGE_RATE = KindDeclaration(
    "station-range-rate", 1, "km/s", "two-way range rate from a ground station to an Earth orbiter")
AZIMUTH = KindDeclaration(
    "azimuth", 1, "rad", "topocentric azimuth at a ground station, from north through east (WGS84 normal)")
ELEVATION = KindDeclaration(
    "elevation", 1, "rad", "topocentric elevation above a ground station's horizon (WGS84 normal)")

#: Every kind, in ICD order.
DECLARED: tuple[KindDeclaration, ...] = (RANGE, DOPPLER, OPTICAL, GENERIC_LINEAR, STATION_RANGE,
                                         STATION_RANGE_RATE, AZIMUTH, ELEVATION)

BY_NAME: dict[str, KindDeclaration] = {k.name: k for k in DECLARED}
NAMES: tuple[str, ...] = tuple(BY_NAME)


def declaration(name: str) -> KindDeclaration:
    """The declaration of kind ``name`` (KeyError naming the known kinds if there is none)."""
    try:
        return BY_NAME[name]
    except KeyError:
        raise KeyError(f"unknown measurement kind {name!r}; declared: {', '.join(NAMES)}") from None


"""Truth DSN station positions: published ITRF coordinates moved by plate motion.

Coordinates of the antenna reference points at epoch 2003.0 and the plate-motion velocities of
each complex from the DSN Telecommunications Link Design Handbook 810-005, module 301
("Coverage and Geometry", Rev. M, 2020, tables of station locations and velocities; the same
numbers are in NAIF's ``earth_topo_201023.tf``). The position at a date is the 2003.0 one plus
velocity x (date - 2003.0): 0.3 m (Goldstone), 0.8 m (Canberra) and 0.5 m (Madrid) in late 2018.
The handbook's frame is ITRF93; the EOP series is consistent with ITRF2020, and the frames differ
by centimetres to a decimetre at the stations, which truth leaves as it is.

The local vertical is the normal to the WGS84 ellipsoid (ERFA ``gc2gd``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import erfa
import numpy as np

_YEAR_S = 365.25 * 86400.0
_T_2003 = 94651200.0  # 2003-01-01T00:00:00 as seconds past J2000 (the scale of so slow a motion's epoch does not matter)

# Plate-motion velocities [m/yr] per complex (810-005 module 301 Rev. M).
_PLATE_M_YR = {
    "goldstone": (-0.0180, 0.0065, -0.0038),
    "canberra": (-0.0335, -0.0041, 0.0392),
    "madrid": (-0.0100, 0.0242, 0.0156),
}


class TruthStationError(ValueError):
    """Unknown station name."""


@dataclass(frozen=True)
class TruthStation:
    name: str
    complex: str
    itrs_2003_m: tuple[float, float, float]

    def itrs_km(self, t_tdb) -> np.ndarray:
        """ITRS position [km] at t_tdb (2003.0 coordinates plus plate motion); (3,) or (N, 3)."""
        years = (np.asarray(t_tdb, dtype=float) - _T_2003) / _YEAR_S
        return (np.array(self.itrs_2003_m) + np.multiply.outer(years, np.array(_PLATE_M_YR[self.complex]))) * 1e-3

    def up_itrs(self, t_tdb: float) -> np.ndarray:
        """Unit normal to the WGS84 ellipsoid at the station."""
        elong, phi, _ = erfa.gc2gd(1, self.itrs_km(t_tdb) * 1e3)
        return np.array([math.cos(phi) * math.cos(elong), math.cos(phi) * math.sin(elong), math.sin(phi)])


STATIONS: dict[str, TruthStation] = {
    "DSS-14": TruthStation("DSS-14", "goldstone", (-2353621.420, -4641341.472, 3677052.318)),
    "DSS-15": TruthStation("DSS-15", "goldstone", (-2353538.958, -4641649.429, 3676669.984)),
    "DSS-43": TruthStation("DSS-43", "canberra", (-4460894.917, 2682361.507, -3674748.152)),
    "DSS-45": TruthStation("DSS-45", "canberra", (-4460935.578, 2682765.661, -3674380.982)),
    "DSS-63": TruthStation("DSS-63", "madrid", (4849092.518, -360180.3480, 4115109.251)),
    "DSS-65": TruthStation("DSS-65", "madrid", (4849339.634, -360427.6637, 4114750.733)),
}

_ALIASES = {
    "dss14": "DSS-14", "goldstone": "DSS-14", "gds": "DSS-14", "gdscc": "DSS-14",
    "dss43": "DSS-43", "canberra": "DSS-43", "cdscc": "DSS-43",
    "dss63": "DSS-63", "madrid": "DSS-63", "mdscc": "DSS-63",
    "dss15": "DSS-15", "dss45": "DSS-45", "dss65": "DSS-65",
}


def station(name: str) -> TruthStation:
    """A station by name or alias ("DSS-14", "dss14", "goldstone", ...)."""
    if not isinstance(name, str):
        raise TruthStationError(f"station name must be a string, got {type(name).__name__}")
    key = name.strip().lower().replace("-", "").replace("_", "").replace(" ", "")
    try:
        return STATIONS[_ALIASES[key]]
    except KeyError:
        raise TruthStationError(
            f"unknown station {name!r}; known: {', '.join(STATIONS)} (aliases: {', '.join(sorted(_ALIASES))})"
        ) from None

"""How far the onboard models (``fsw/astro``) are from the simulator's truth models (``sim/truth``).

Each figure is a maximum (and where useful an RMS) over a mission span sampled every 10 min:
the last 45 days of the InSight approach and the Mars Pathfinder cruise. The onboard model is
simpler where a flight computer would be (IAU 2000B nutation, weekly uploaded Earth orientation,
a truncated TDB-TT series); the filter covers what is left as measurement noise — these numbers
show it is below the radiometric noise (1 m range, 0.1 mm/s Doppler).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.astro import earth as onboard_earth
from fsw.astro import mars as onboard_mars
from fsw.astro import moons as onboard_moons
from fsw.astro import stations as onboard_stations
from fsw.astro import time as onboard_time
from sim.truth import mars as truth_mars
from sim.truth import moons as truth_moons
from sim.truth import stations as truth_stations
from sim.truth import timescales as truth_time
from sim.truth.earth import EarthOrientation

SPANS = {
    "InSight approach (2018-10-12 to 2018-11-26)": ("2018-10-12T00:00:00", 45.0),
    "Pathfinder cruise (1996-12-04 to 1997-07-04)": ("1996-12-04T00:00:00", 212.0),
}
STATIONS = ("DSS-14", "DSS-43", "DSS-63")


@dataclass(frozen=True)
class Difference:
    model: str
    quantity: str
    unit: str
    maximum: float
    rms: float


def _stats(x: np.ndarray) -> tuple[float, float]:
    return float(np.max(np.abs(x))), float(np.sqrt(np.mean(np.square(x))))


def measure(start_utc: str, days: float, step_s: float = 600.0) -> list[Difference]:
    """Onboard minus truth over ``days`` from ``start_utc``."""
    t0 = truth_time.utc_iso_to_tdb(start_utc)
    t = t0 + np.arange(0.0, days * 86400.0, step_s)
    out: list[Difference] = []

    def add(model: str, quantity: str, unit: str, values: np.ndarray) -> None:
        out.append(Difference(model, quantity, unit, *_stats(values)))

    add("time", "TDB-TT (onboard 7-term series vs Fairhead & Bretagnon)", "us",
        (np.asarray(onboard_time.tdb_minus_tt(t)) - np.asarray(truth_time.tdb_minus_tt(t))) * 1e6)
    add("time", "UTC of a TDB epoch", "us",
        (np.asarray(onboard_time.tdb_to_unix(t)) - np.asarray(truth_time.tdb_to_unix(t))) * 1e6)
    eo = EarthOrientation(float(t[0]), float(t[-1]))
    for name in STATIONS:
        r = np.asarray(truth_stations.station(name).itrs_km(t))
        p_true, v_true = eo.state(r[..., None], t)
        p_on, v_on = onboard_earth.itrs_to_gcrs_state(r[0], t)
        add("Earth orientation", f"GCRS position of {name}'s ITRS point", "m",
            np.linalg.norm(p_on - p_true[..., 0], axis=1) * 1e3)
        add("Earth orientation", f"GCRS velocity of {name}'s ITRS point", "mm/s",
            np.linalg.norm(v_on - v_true[..., 0], axis=1) * 1e6)
        add("stations", f"{name} ITRS position (onboard at the span's start, truth drifting)", "m",
            np.linalg.norm(onboard_stations.station(name).itrs_at(float(t[0])) - r, axis=1) * 1e3)
    for moon in ("phobos", "deimos"):
        p_on, v_on = onboard_moons.moon_state(moon, t)
        p_true, v_true = truth_moons.moon_state(moon, t)
        add("moons", f"{moon} position", "m", np.linalg.norm(p_on - p_true, axis=1) * 1e3)
        add("moons", f"{moon} velocity", "m/s", np.linalg.norm(v_on - v_true, axis=1) * 1e3)
    pole_on = onboard_mars.MARS_EQUATOR_TO_ICRF[:, 2]
    ang = [np.degrees(np.arccos(np.clip(pole_on @ truth_mars.body_fixed_to_icrf_matrix(float(tk))[:, 2], -1, 1)))
           for tk in t[:: max(1, t.size // 50)]]
    add("Mars orientation", "north pole direction (onboard fixed at J2000, truth drifting)", "deg", np.array(ang))
    return out


def table_rows() -> list[list[str]]:
    """Rows [span, model, quantity, max, rms] for the validation document."""
    rows = []
    for span, (start, days) in SPANS.items():
        for d in measure(start, days):
            rows.append([span, d.model, d.quantity, f"{d.maximum:.3g} {d.unit}", f"{d.rms:.3g} {d.unit}"])
    return rows


if __name__ == "__main__":
    for row in table_rows():
        print(" | ".join(row))

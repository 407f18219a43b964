"""One-way uplink range and Doppler from the DSN, received and time-tagged by the onboard clock.

Observables (Lubey & Ely 2022 §4.1: one-way radiometric data with a DSAC-class onboard clock):

* **Range** [km]: ``rho = c (T_rx - t_tx)`` where ``T_rx = t_rx + b(t_rx)`` is the onboard clock
  reading at the true reception time t_rx (b = clock phase error, :mod:`sim.clock`) and t_tx the
  TDB transmit time at the station, from the uplink light-time equation
  ``|r_sc(t_rx) - r_stn(t_tx)| = c (t_rx - t_tx)`` (station moving with Earth's rotation; see
  :mod:`sim.sensors.lighttime`). Hence ``rho = c tau + c b(t_rx)``: a clock phase error appears
  as a range error c·b. Positive, increasing with distance.
* **Doppler** [km/s]: one-way range rate over the count interval ending at the time tag,
  ``(rho(t_rx) - rho(t_rx - T_c)) / T_c`` with T_c the count time. It equals the geometric
  range rate plus ``c (b(t_rx) - b(t_rx - T_c)) / T_c`` ~ ``c f`` (f = clock frequency error).
  Sign: positive when the range grows (spacecraft receding). In frequency units the one-way
  Doppler shift is f_D = -(F / c) * value, F the X-band uplink carrier the spacecraft receives
  (``fsw.interface.kinds.DOPPLER_CARRIER_HZ``, ``fsw.astro.constants.MHZ_TO_KM_S``).
* **Time tag** = onboard clock reading at reception, ``t_rx + b(t_rx)``.

Elevation is that of the uplink at the station at the transmit time, towards the spacecraft's
position at reception (geodetic horizon); both ends of a Doppler count must be above the
minimum. The tracking schedule is described in :mod:`sim.sensors.config`: either the daily
passes, each flown by the station that sees the spacecraft best, or a pass plan of periodic
passes per station, each centred on the spacecraft's transit at that station.

Noise is drawn per *schedule slot* — every range/Doppler slot of every pass, before knowing
which slots the geometry keeps — so the draws of a given slot never depend on the trajectory,
the station choice or on faults.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import C_KM_S
from sim.clock import ClockTruth
from sim.sensors.config import RadiometricConfig
from sim.sensors.geometry import Scene
from sim.sensors.lighttime import light_time
from sim.truth.stations import station


@dataclass(frozen=True)
class RadioSchedule:
    """Tracking passes and the measurement slots inside them (true reception times, TDB)."""

    pass_start: np.ndarray  # (P,)
    pass_end: np.ndarray  # (P,)
    range_t: np.ndarray  # (R,) reception times of range slots
    range_pass: np.ndarray  # (R,) pass index of each range slot
    doppler_t: np.ndarray  # (D,) reception times at the end of each Doppler count
    doppler_pass: np.ndarray  # (D,)


@dataclass(frozen=True)
class RadioData:
    """Radiometric measurements kept after geometry (arrays of equal length, by reception time).

    ``clean`` is the noise-free observable (clock errors and the run's range bias included),
    ``noise`` the drawn noise;
    the reported value is ``clean + noise`` plus any measurement-bias fault.
    """

    t_rx: np.ndarray
    kind: np.ndarray  # "range" | "doppler"
    station: np.ndarray  # station name per measurement
    clean: np.ndarray  # km (range) or km/s (doppler)
    noise: np.ndarray
    sigma: np.ndarray
    elevation_rad: np.ndarray
    light_time_s: np.ndarray
    slot: np.ndarray  # index in the schedule's range_t or doppler_t
    range_bias_km: float = 0.0  # the run's constant range bias, included in ``clean``

    def __len__(self) -> int:
        return int(self.t_rx.size)


_TRANSIT_GRID_S = 600.0


def plan_passes(cfg: RadiometricConfig, scene: Scene, t_start: float, t_end: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(start, end, station) of every pass of ``cfg.pass_plan``, by start time.

    The pass of day d is centred on the highest elevation of the spacecraft at the station over
    [t_start + d days, t_start + d + 1 days), sampled on a 10-min grid, and clipped to the run."""
    starts, ends, names = [], [], []
    for p in cfg.pass_plan:
        days = np.arange(p.first_day, (t_end - t_start) / 86400.0, p.period_days)
        if days.size == 0:
            continue
        grid = np.arange(0.0, 86400.0, _TRANSIT_GRID_S)
        t = (t_start + days[:, None] * 86400.0 + grid[None, :]).ravel()
        inside = t <= t_end
        el = np.full(t.size, -np.inf)
        el[inside] = uplink(scene, p.station, t[inside])[1]
        centre = t.reshape(days.size, grid.size)[np.arange(days.size), np.argmax(el.reshape(days.size, -1), axis=1)]
        half = 0.5 * p.duration_h * 3600.0
        a, b = np.maximum(centre - half, t_start), np.minimum(centre + half, t_end)
        keep = b > a
        starts.append(a[keep])
        ends.append(b[keep])
        names.append(np.full(int(keep.sum()), station(p.station).name, dtype=object))
    if not starts:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=object)
    ps, pe, st = np.concatenate(starts), np.concatenate(ends), np.concatenate(names)
    order = np.argsort(ps, kind="stable")
    return ps[order], pe[order], st[order]


def make_schedule(cfg: RadiometricConfig, t_start: float, t_end: float,
                  passes: tuple[np.ndarray, np.ndarray] | None = None) -> RadioSchedule:
    """Passes every 24 h / passes_per_day from ``t_start + first_pass_offset`` (or the given
    ``passes`` (start, end)); slots on exact grids from each pass start."""
    empty = np.zeros(0)
    empty_i = np.zeros(0, dtype=np.int64)
    if passes is not None:
        ps, pe = (np.asarray(v, dtype=float) for v in passes)
    else:
        if cfg.passes_per_day == 0 or t_end <= t_start:
            return RadioSchedule(empty, empty, empty, empty_i, empty, empty_i)
        spacing = 86400.0 / cfg.passes_per_day
        first = t_start + cfg.first_pass_offset_h * 3600.0
        n = max(int(np.ceil((t_end - first) / spacing)), 0)
        ps = first + spacing * np.arange(n)
        pe = np.minimum(ps + cfg.pass_duration_h * 3600.0, t_end)
    keep = pe > ps
    ps, pe = ps[keep], pe[keep]

    def grid(start_offset: float, step: float) -> tuple[np.ndarray, np.ndarray]:
        ts, idx = [], []
        for k, (a, b) in enumerate(zip(ps, pe)):
            m = int(np.floor((b - a - start_offset) / step + 1e-9)) + 1
            if m > 0:
                ts.append(a + start_offset + step * np.arange(m))
                idx.append(np.full(m, k, dtype=np.int64))
        if not ts:
            return empty, empty_i
        return np.concatenate(ts), np.concatenate(idx)

    rt, rp = grid(0.0, cfg.range_interval_s) if cfg.range_enabled else (empty, empty_i)
    dt, dp = grid(cfg.doppler_count_s, cfg.doppler_interval_s) if cfg.doppler_enabled else (empty, empty_i)
    return RadioSchedule(ps, pe, rt, rp, dt, dp)


def uplink(scene: Scene, station: str, t_rx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Uplink light time [s] and station elevation at transmit [rad] for receptions at t_rx."""
    t_rx = np.asarray(t_rx, dtype=float)
    r_sc = scene.sc(t_rx)
    tau, _ = light_time(t_rx, r_sc, scene.station(station), emitter_state=scene.station_state(station))
    t_tx = t_rx - tau
    geocentric_target = r_sc - scene.body("earth", t_tx)
    el = scene.elevation(station, t_tx, geocentric_target)
    return tau, el


def choose_stations(cfg: RadiometricConfig, scene: Scene, sched: RadioSchedule, samples: int = 7) -> np.ndarray:
    """For each pass, the station whose lowest elevation over the pass is highest."""
    if sched.pass_start.size == 0:
        return np.zeros(0, dtype=object)
    frac = np.linspace(0.0, 1.0, samples)
    t = (sched.pass_start[:, None] + (sched.pass_end - sched.pass_start)[:, None] * frac).ravel()
    worst = np.stack([uplink(scene, s, t)[1].reshape(-1, samples).min(axis=1) for s in cfg.stations], axis=1)
    return np.array(cfg.stations, dtype=object)[np.argmax(worst, axis=1)]


def one_way_range(tau: np.ndarray, phase_s: np.ndarray) -> np.ndarray:
    """Range [km] = c (clock reading at reception - transmit TDB) = c (tau + b)."""
    return C_KM_S * (tau + phase_s)


def simulate_radiometric(
    cfg: RadiometricConfig,
    scene: Scene,
    clock: ClockTruth,
    t_start: float,
    t_end: float,
    rng: np.random.Generator,
) -> tuple[RadioSchedule, RadioData]:
    """Schedule, geometry, clock and noise of every one-way range and Doppler measurement.

    ``rng`` is this sensor's own stream: it draws one range normal per range slot, then one
    Doppler normal per Doppler slot, then the run's range bias, always in that order and amount.
    """
    if cfg.pass_plan:
        ps, pe, stations = plan_passes(cfg, scene, t_start, t_end)
        sched = make_schedule(cfg, t_start, t_end, (ps, pe))
        names = tuple(dict.fromkeys(stations.tolist()))
    else:
        sched = make_schedule(cfg, t_start, t_end)
        names = cfg.stations
    z_range = rng.standard_normal(sched.range_t.size)
    z_doppler = rng.standard_normal(sched.doppler_t.size)
    range_bias = cfg.range_bias_sigma_m * 1e-3 * float(rng.standard_normal())  # drawn last: earlier draws keep their values
    if not cfg.pass_plan:
        stations = choose_stations(cfg, scene, sched)
    min_el = np.radians(cfg.min_elevation_deg)
    sig_r = cfg.range_sigma_m * 1e-3
    sig_d = cfg.doppler_sigma_mm_s * 1e-6
    tc = cfg.doppler_count_s
    parts = []
    for name in names:
        r_idx = np.flatnonzero(stations[sched.range_pass] == name) if sched.range_t.size else np.zeros(0, int)
        d_idx = np.flatnonzero(stations[sched.doppler_pass] == name) if sched.doppler_t.size else np.zeros(0, int)
        if r_idx.size + d_idx.size == 0:
            continue
        t_r = sched.range_t[r_idx]
        t_de = sched.doppler_t[d_idx]
        times, inv = np.unique(np.concatenate((t_r, t_de, t_de - tc)), return_inverse=True)
        tau, el = uplink(scene, name, times)
        rho = one_way_range(tau, clock.phase(times))
        nr, nd = t_r.size, t_de.size
        i_r, i_e, i_s = inv[:nr], inv[nr:nr + nd], inv[nr + nd:]
        keep_r = el[i_r] >= min_el
        keep_d = (el[i_e] >= min_el) & (el[i_s] >= min_el)
        parts.append(dict(
            t_rx=np.concatenate((t_r[keep_r], t_de[keep_d])),
            kind=np.array(["range"] * int(keep_r.sum()) + ["doppler"] * int(keep_d.sum()), dtype=object),
            station=np.full(int(keep_r.sum() + keep_d.sum()), name, dtype=object),
            clean=np.concatenate((rho[i_r][keep_r] + range_bias, ((rho[i_e] - rho[i_s]) / tc)[keep_d])),
            noise=np.concatenate((sig_r * z_range[r_idx][keep_r], sig_d * z_doppler[d_idx][keep_d])),
            sigma=np.concatenate((np.full(int(keep_r.sum()), sig_r), np.full(int(keep_d.sum()), sig_d))),
            elevation_rad=np.concatenate((el[i_r][keep_r], el[i_e][keep_d])),
            light_time_s=np.concatenate((tau[i_r][keep_r], tau[i_e][keep_d])),
            slot=np.concatenate((r_idx[keep_r], d_idx[keep_d])),
        ))
    keys = ("t_rx", "kind", "station", "clean", "noise", "sigma", "elevation_rad", "light_time_s", "slot")
    if not parts:
        return sched, RadioData(**{k: np.zeros(0, dtype=object if k in ("kind", "station") else float) for k in keys},
                                range_bias_km=range_bias)
    merged = {k: np.concatenate([p[k] for p in parts]) for k in keys}
    # Range before Doppler at equal times, so the order never depends on the station loop.
    order = np.lexsort((merged["kind"] == "doppler", merged["t_rx"]))
    return sched, RadioData(**{k: v[order] for k, v in merged.items()}, range_bias_km=range_bias)

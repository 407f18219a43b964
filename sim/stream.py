"""The measurement stream: one simulated run as time-ordered ICD messages.

:func:`generate` flies the truth trajectory and clock, makes every measurement, injects the
faults and returns a :class:`SimRun`: sequence-numbered :class:`~fsw.interface.messages.Measurement`s
in time order, :class:`~fsw.interface.messages.Truth` at a cadence (exact truth at any time
through :meth:`SimRun.truth_at`), and :class:`~fsw.interface.messages.FaultEvent`s.

Randomness. ``numpy.random.SeedSequence(seed).spawn`` gives each component its own child stream,
always in the order of :data:`COMPONENTS`; each component draws a fixed amount per schedule slot
whatever the geometry or the faults. So the same seed gives a bit-identical run, and a faulted
run differs from the un-faulted one with the same seed *only* by the fault.
"""

from __future__ import annotations

import gc
import math
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from sim.truth.timescales import tdb_to_unix, utc_iso_to_tdb
from fsw.interface import topics
from fsw.interface.messages import FaultEvent, Measurement, Stamp, Truth
from sim.clock import ClockTruth, simulate_clock
from sim.config import SimConfig
from sim.dynamics.propagator import Trajectory
from sim.faults.apply import (
    FaultWindow,
    active_ids,
    clock_steps,
    doppler_bias_km_s,
    fault_events,
    fault_windows,
    optical_bias_px,
    range_bias_km,
)
from sim.faults.config import FaultConfig
from sim.faults.dynamics import apply_dynamics_faults
from sim.sensors.geometry import Scene
from sim.sensors.optical import OpticalData, simulate_optical
from sim.sensors.radiometric import RadioData, simulate_radiometric
from sim.trajectories.design import arc_span, build_truth_trajectory
from sim.scenarios.leo_injection import generate as leo_generate

#: Components with their own random stream, in spawn order (append only: never reorder;
#: a spawned child depends only on its index, so appending leaves the others unchanged).
COMPONENTS: tuple[str, ...] = ("trajectory", "clock", "radiometric", "optical", "nga")

_CLOCK_MARGIN_S = 3600.0


def component_seeds(seed: int) -> dict[str, np.random.SeedSequence]:
    """Independent child seed sequences of ``seed``, one per component."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    children = np.random.SeedSequence(int(seed)).spawn(len(COMPONENTS))
    return dict(zip(COMPONENTS, children))


def _stamps(t_tdb: np.ndarray) -> list[Stamp]:
    """:meth:`Stamp.from_unix` of each time's Unix seconds, its arithmetic done on the array (floor,
    round half to even, the carry and the clamp at 0 are what it does to each float)."""
    unix = np.atleast_1d(np.asarray(tdb_to_unix(np.asarray(t_tdb, dtype=float)), dtype=float))
    sec = np.floor(unix)
    nsec = np.rint((unix - sec) * 1e9)
    carry = nsec >= 1e9
    sec, nsec = np.where(carry, sec + 1.0, sec), np.where(carry, nsec - 1e9, nsec)
    return [Stamp(s, n) for s, n in zip(np.maximum(sec, 0.0).astype(np.int64).tolist(),
                                        nsec.astype(np.int64).tolist())]


@dataclass
class SimRun:
    """One simulated run: messages plus the truth objects behind them.

    ``t_true[k]`` is the true (TDB) reception time of ``measurements[k]``; ``origin[k]`` is
    ``"radio"`` or ``"optical"`` (``"linear"`` for wrapped linear scenarios) and ``index[k]`` the
    row in ``radio``/``optical`` that produced it.
    """

    measurements: list[Measurement]
    truth: list[Truth]
    fault_events: list[FaultEvent]
    t_start: float
    t_end: float
    seed: int | None = None
    t_true: np.ndarray = field(default_factory=lambda: np.zeros(0))
    origin: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object))
    index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    trajectory: Trajectory | None = None
    clock: ClockTruth | None = None
    windows: tuple[FaultWindow, ...] = ()
    radio: RadioData | None = None
    optical: OpticalData | None = None
    config: SimConfig | None = None

    def truth_at(self, t_tdb: float) -> Truth:
        """Exact truth at any true TDB time inside the run (for scoring)."""
        if self.trajectory is None or self.clock is None:
            raise ValueError("this run has no trajectory/clock truth (a linear scenario)")
        return _truth_messages(self.trajectory, self.clock, self.windows, np.array([float(t_tdb)]))[0]

    def state_at(self, t_tdb) -> np.ndarray:
        """True Mars-centred ICRF state(s) [km, km/s] at TDB time(s)."""
        if self.trajectory is None:
            raise ValueError("this run has no trajectory truth (a linear scenario)")
        return self.trajectory.state(t_tdb)

    def iter_messages(self) -> Iterator[tuple[str, FaultEvent | Truth | Measurement]]:
        """(topic, message) for every message in time order (fault events, then truth, then
        measurements at equal times). Topics are the bare ``fsw.interface.topics`` names."""
        return iter(self.messages())

    def messages(self) -> list[tuple[str, FaultEvent | Truth | Measurement]]:
        """The (topic, message) pairs of :meth:`iter_messages`, in that order, as one list.

        Ordered by (time, fault/truth/measurement, index) in one sort of the three streams'
        times; merging them pair by pair cost 0.7 µs a measurement in the loop that feeds the
        in-process FSW core."""
        t_meas = self.t_true if self.t_true.size == len(self.measurements) else [m.t_s for m in self.measurements]
        streams: list[tuple[str, list[FaultEvent] | list[Truth] | list[Measurement], np.ndarray]] = [
            (topics.SIM_FAULTS, self.fault_events, np.array([e.t_s for e in self.fault_events], dtype=float)),
            (topics.SIM_TRUTH, self.truth, np.array([m.t_s for m in self.truth], dtype=float)),
            (topics.SIM_MEASUREMENTS, self.measurements, np.asarray(t_meas, dtype=float)),
        ]
        pairs: list[tuple[str, FaultEvent | Truth | Measurement]] = []
        for topic, msgs, _ in streams:
            pairs.extend([(topic, msg) for msg in msgs])
        t = np.concatenate([times for _, _, times in streams])
        rank = np.concatenate([np.full(len(msgs), k) for k, (_, msgs, _) in enumerate(streams)])
        # lexsort: the last key first; the concatenation's position is the index within a stream
        order = np.lexsort((np.arange(t.size), rank, t))
        return [pairs[i] for i in order.tolist()]

    def counts(self) -> dict[str, int]:
        """Number of measurements per kind."""
        out: dict[str, int] = {}
        for m in self.measurements:
            out[m.kind] = out.get(m.kind, 0) + 1
        return out


def _truth_messages(trajectory, clock: ClockTruth, windows, t: np.ndarray) -> list[Truth]:
    x = np.atleast_2d(trajectory.state(t))
    b, f, a = clock.state(t)
    srp = np.atleast_1d(trajectory.srp_scale(t))
    acs = np.atleast_2d(trajectory.acs_accel(t))
    ids = active_ids(windows, t)
    stamps = _stamps(t)
    rows = zip(np.asarray(t, dtype=float).tolist(), np.asarray(x, dtype=float).tolist(),
               *(np.asarray(v, dtype=float).ravel().tolist() for v in (b, f, a, srp)),
               np.asarray(acs, dtype=float).tolist(), ids, stamps)
    return [
        Truth(t_s=tk, timestamp=stamp, position_km=tuple(xk[:3]), velocity_km_s=tuple(xk[3:]), clock_phase_s=bk,
              clock_frequency=fk, clock_drift_per_s=ak, srp_scale=sk, acs_accel_km_s2=tuple(acc), active_faults=idk)
        for tk, xk, bk, fk, ak, sk, acc, idk, stamp in rows
    ]


def scenario_span(cfg: SimConfig) -> tuple[float, float]:
    """(t_start, t_end) TDB of the run (the approach arc ending at entry, the cruise arc, or the
    tracking arc after an Earth-orbit injection)."""
    if cfg.leo is not None:
        t0 = utc_iso_to_tdb(cfg.leo.epoch_utc)
        return t0, t0 + cfg.leo.arc_s
    return arc_span(cfg.trajectory)


def leo_run(cfg: SimConfig, seed: int) -> SimRun:
    """One run of the Earth-orbit injection case (``cfg.leo``): its measurements, and Truth
    messages (Earth-centred GCRS state; no clock or force parameters) every ``truth_interval_s``."""
    assert cfg.leo is not None
    run = leo_generate(cfg.leo, seed)
    every = max(1, int(round(cfg.truth_interval_s * cfg.leo.rate_hz))) if cfg.truth_interval_s > 0.0 else 1
    idx = np.arange(0, run.t.size, every)
    stamps = _stamps(run.t[idx])
    truth = [Truth(t_s=float(run.t[k]), timestamp=stamps[j], position_km=tuple(float(v) for v in run.truth[k, 0:3]),
                   velocity_km_s=tuple(float(v) for v in run.truth[k, 3:6]), clock_phase_s=0.0, clock_frequency=0.0,
                   clock_drift_per_s=0.0)
             for j, k in enumerate(idx)]
    t_meas = np.array([m.t_s for m in run.measurements])
    return SimRun(measurements=run.measurements, truth=truth, fault_events=[], t_start=float(run.t[0]),
                  t_end=float(run.t[-1]), seed=int(seed), t_true=t_meas,
                  origin=np.full(t_meas.size, "leo", dtype=object), index=np.arange(t_meas.size, dtype=np.int64),
                  config=cfg)


def generate(cfg: SimConfig = SimConfig(), faults: tuple[FaultConfig, ...] | None = None, seed: int = 0) -> SimRun:
    """Simulate one run. ``faults`` replaces ``cfg.faults`` when given (e.g. a preset).

    The cyclic collector is held off while the run is made: its ~100k acyclic messages would
    otherwise trigger repeated full passes (~0.09 s of a ~0.65 s default run)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        return _generate(cfg, faults, seed)
    finally:
        if was_enabled:
            gc.enable()


def _generate(cfg: SimConfig, faults: tuple[FaultConfig, ...] | None, seed: int) -> SimRun:
    if cfg.leo is not None:
        if faults:
            raise ValueError("faults are not available in the Earth-orbit (leo) case")
        return leo_run(cfg, seed)
    faults = tuple(cfg.faults if faults is None else faults)
    seeds = component_seeds(seed)
    t_start, t_end = scenario_span(cfg)
    windows = fault_windows(faults, t_start)
    for w in windows:
        if w.t_on > t_end:
            raise ValueError(f"fault {w.id} starts after the end of the run")

    nominal = build_truth_trajectory(cfg.trajectory, cfg.forces, np.random.default_rng(seeds["trajectory"]),
                                     np.random.default_rng(seeds["nga"]))
    trajectory = apply_dynamics_faults(
        nominal, cfg.trajectory, cfg.forces, windows, lambda: np.random.default_rng(seeds["trajectory"])
    )
    clock = simulate_clock(cfg.clock, t_start - _CLOCK_MARGIN_S, t_end + _CLOCK_MARGIN_S,
                           np.random.default_rng(seeds["clock"]))
    clock = clock.with_steps(clock_steps(windows))
    scene = Scene(trajectory.position, t_start, t_end, step_s=cfg.trajectory.ephemeris_step_s)

    _, radio = simulate_radiometric(cfg.radiometric, scene, clock, t_start, t_end,
                                    np.random.default_rng(seeds["radiometric"]))
    optical = simulate_optical(cfg.optical, scene, t_start, t_end, np.random.default_rng(seeds["optical"]))

    is_range = radio.kind == "range"
    r_bias = np.where(is_range, range_bias_km(windows, radio.t_rx), doppler_bias_km_s(windows, radio.t_rx))
    radio_value = radio.clean + radio.noise + r_bias
    opt_value = optical.clean + optical.noise + optical_bias_px(windows, optical.t_rx)

    # Merge by true reception time; at equal times range, Doppler, then optical.
    t_all = np.concatenate((radio.t_rx, optical.t_rx))
    rank = np.concatenate((np.where(is_range, 0, 1), np.full(len(optical), 2)))
    origin = np.array(["radio"] * len(radio) + ["optical"] * len(optical), dtype=object)
    index = np.concatenate((np.arange(len(radio)), np.arange(len(optical)))).astype(np.int64)
    order = np.lexsort((rank, t_all))
    t_true = t_all[order]
    tags = t_true + clock.phase(t_true) if t_true.size else t_true
    stamps = _stamps(tags) if t_true.size else []

    measurements: list[Measurement] = []
    count_s = float(cfg.radiometric.doppler_count_s)
    # Python scalars of every column once (tolist gives the same floats as float() of each element).
    r_kind, r_station = [str(v) for v in radio.kind.tolist()], [str(v) for v in radio.station.tolist()]
    r_value, r_sigma = np.asarray(radio_value, dtype=float).tolist(), np.asarray(radio.sigma, dtype=float).tolist()
    o_target = [str(v) for v in optical.target.tolist()]
    o_value = np.asarray(opt_value, dtype=float).reshape(-1, 2).tolist()
    o_sigma = np.asarray(optical.sigma, dtype=float).reshape(-1, 2).tolist()
    o_q = np.asarray(optical.attitude_q, dtype=float).reshape(-1, 4).tolist()
    is_radio = (origin[order] == "radio").tolist()
    for seq, (i, tag, radio_row) in enumerate(zip(index[order].tolist(), tags.tolist(), is_radio)):
        # by position (seq, t_s, timestamp, kind, source, value, sigma, attitude_q, count_time_s):
        # a measurement each
        if radio_row:
            kind = r_kind[i]
            measurements.append(Measurement(seq, tag, stamps[seq], kind, r_station[i], (r_value[i],), (r_sigma[i],),
                                            None, count_s if kind == "doppler" else None))
        else:
            measurements.append(Measurement(seq, tag, stamps[seq], "optical", o_target[i], tuple(o_value[i]),
                                            tuple(o_sigma[i]), tuple(o_q[i])))

    if cfg.truth_interval_s > 0.0:
        n = int(math.floor((t_end - t_start) / cfg.truth_interval_s + 1e-9)) + 1
        t_truth = t_start + cfg.truth_interval_s * np.arange(n)
    else:
        t_truth = np.unique(t_true)
    truth = _truth_messages(trajectory, clock, windows, t_truth) if t_truth.size else []

    return SimRun(
        measurements=measurements,
        truth=truth,
        fault_events=fault_events(windows, t_end),
        t_start=t_start,
        t_end=t_end,
        seed=int(seed),
        t_true=t_true,
        origin=origin[order],
        index=index[order],
        trajectory=trajectory,
        clock=clock,
        windows=windows,
        radio=radio,
        optical=optical,
        config=cfg,
    )


def linear_tracking_run(track, source: str = "chaer-tracking", t0_tdb: float = 0.0) -> SimRun:
    """Wrap a linear tracking sequence (``sim.scenarios.chaer_tracking.TrackingRun``) as a run of
    ``generic-linear`` measurements: value z_k, sigma sqrt(r1), sqrt(r2) of its noise segment,
    time tag ``t0_tdb + t_k``. The linear truth stays in ``track`` (no Truth messages)."""
    t = t0_tdb + np.asarray(track.t, dtype=float)
    z = np.asarray(track.z, dtype=float)
    alpha = np.asarray(track.alpha, dtype=float)
    sig = np.sqrt(alpha[np.asarray(track.segment), 2:4])
    if not (np.all(np.isfinite(z)) and np.all(sig > 0.0)):
        raise ValueError("linear measurements need finite values and positive noise variances")
    stamps = _stamps(t)
    meas = [
        Measurement(seq=k, t_s=float(t[k]), timestamp=stamps[k], kind="generic-linear", source=source,
                    value=tuple(float(v) for v in z[k]), sigma=tuple(float(s) for s in sig[k]))
        for k in range(t.size)
    ]
    return SimRun(
        measurements=meas, truth=[], fault_events=[], t_start=float(t[0]) if t.size else t0_tdb,
        t_end=float(t[-1]) if t.size else t0_tdb, t_true=t, origin=np.full(t.size, "linear", dtype=object),
        index=np.arange(t.size, dtype=np.int64),
    )

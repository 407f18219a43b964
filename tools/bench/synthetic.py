"""An InSight-like approach measurement stream made with the onboard models themselves.

Used by the benchmark when no simulator stream is requested, and by tests that need realistic
geometry. It is NOT an independent truth (the simulator is): the trajectory comes from the
onboard force model with fixed "true" parameters, and the measurements from the onboard
measurement models plus white noise.

Geometry: entry interface 2018-11-26T19:47 UTC at 3522.2 km from Mars' centre, 5.75 km/s,
flight-path angle −12° (DESIGN.md); the state ``span_days`` earlier comes from integrating
back. Tracking: three 3-hour passes a day over DSS-14/43/63 (range every 600 s, 60-s Doppler
every 60 s), one image every 1800 s cycling Mars, Phobos, Deimos with the boresight on the
target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.frames import matrix_to_quat
from fsw.astro.time import tdb_to_unix, utc_iso_to_tdb
from fsw.filters.config import BankConfig, FilterConfig
from fsw.filters.ekf import EKFStack
from fsw.filters.optical_kind import predict_optical
from fsw.filters.radiometric_kinds import predict_doppler, predict_range
from fsw.interface.messages import Measurement, Stamp
from fsw.models.environment import Environment

ENTRY_UTC = "2018-11-26T19:47:00"
STATIONS = ("DSS-14", "DSS-43", "DSS-63")


@dataclass(frozen=True)
class SyntheticRun:
    t0: float
    position_km: np.ndarray  # true initial state
    velocity_km_s: np.ndarray
    measurements: tuple[Measurement, ...]
    truth: dict[float, np.ndarray]  # t -> true [r, v]


def entry_state() -> tuple[float, np.ndarray, np.ndarray]:
    """(t_entry, r, v): a descending entry state, −12° flight-path angle."""
    t_e = utc_iso_to_tdb(ENTRY_UTC)
    up = np.array([0.3, -0.8, 0.52])
    up /= np.linalg.norm(up)
    side = np.cross(np.array([0.0, 0.0, 1.0]), up)
    side /= np.linalg.norm(side)
    g = math.radians(-12.0)
    r = 3522.2 * up
    v = 5.75 * (math.sin(g) * up + math.cos(g) * side)
    return t_e, r, v


def _camera_to_icrf(boresight: np.ndarray) -> np.ndarray:
    z = boresight / np.linalg.norm(boresight)
    x = np.cross(np.array([0.0, 0.0, 1.0]), z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=-1)


def make_run(span_days: float = 45.0, end_offset_h: float = 6.0, seed: int = 1, optical: bool = True,
             radio: bool = True, env: Environment | None = None, max_measurements: int | None = None) -> SyntheticRun:
    """Generate a measurement stream over the ``span_days`` before entry (stopping
    ``end_offset_h`` before it)."""
    env = env if env is not None else Environment()
    rng = np.random.default_rng(seed)
    t_e, r_e, v_e = entry_state()
    truth_cfg = BankConfig(filters=(FilterConfig(name="truth"),), max_step_s=600.0)
    tr = EKFStack(truth_cfg, t_e, r_e, v_e, env)
    t0 = t_e - span_days * 86400.0
    r0, v0, _ = tr.propagator.propagate(t_e, t0, r_e[None], v_e[None], tr.drivers(), with_stm=False)
    truth = EKFStack(truth_cfg, t0, r0[0], v0[0], env)
    # truth parameters: clock phase 0.3 µs, SRP scale +5 %, ACS +2 %
    L = truth.layout
    truth.x[0, L.slices["srp_bias"]] = 0.05
    truth.x[0, L.slices["acs_bias"]] = 0.02
    truth.x[0, L.slices["clock"].start] = 3e-7
    truth.batched = []  # deterministic truth parameters
    truth.P[:] = 0.0
    t_end = t_e - end_offset_h * 3600.0
    events: list[tuple[float, str, str]] = []
    if radio:
        for day in range(int(math.ceil(span_days))):
            for p in range(3):
                start = t0 + day * 86400.0 + p * 8 * 3600.0 + 1800.0
                st = STATIONS[(day + p) % 3]
                for k in range(0, 3 * 3600, 60):
                    t = start + k
                    events.append((t, "doppler", st))
                    if k % 600 == 0:
                        events.append((t + 30.0, "range", st))
    if optical:
        targets = ("mars", "phobos", "deimos")
        for j, t in enumerate(np.arange(t0 + 900.0, t_end, 1800.0)):
            events.append((float(t), "optical", targets[j % 3]))
    events = sorted(e for e in events if t0 < e[0] < t_end)
    if max_measurements is not None:
        events = events[:max_measurements]
    out: list[Measurement] = []
    states: dict[float, np.ndarray] = {}
    for seq, (t, kind, source) in enumerate(events):
        truth.propagate_to(t)
        x = truth.x
        states[t] = x[0, :6].copy()
        if kind == "range":
            h, _ = predict_range(truth, source, t, x)
            sigma: tuple[float, ...] = (1e-3,)
            value: tuple[float, ...] = (float(h[0, 0] + rng.normal(0.0, sigma[0])),)
            q: tuple[float, ...] | None = None
            count = None
        elif kind == "doppler":
            h, _ = predict_doppler(truth, source, t, 60.0, x)
            sigma = (1e-7,)
            value = (float(h[0, 0] + rng.normal(0.0, sigma[0])),)
            q = None
            count = 60.0
        else:
            r_t, _ = env.target_state(source, t)
            C = _camera_to_icrf(r_t - x[0, 0:3] + rng.normal(0.0, 1e-3, 3) * np.linalg.norm(r_t - x[0, 0:3]))
            q = tuple(float(c) for c in matrix_to_quat(C))
            h, _ = predict_optical(truth, source, t, q, x)
            sigma = (0.3, 0.3)
            value = tuple(float(v) for v in h[0] + rng.normal(0.0, 0.3, 2))
            count = None
        out.append(Measurement(seq=seq, t_s=float(t), timestamp=Stamp.from_unix(float(tdb_to_unix(t))), kind=kind,
                               source=source, value=value, sigma=sigma, attitude_q=q, count_time_s=count))
    return SyntheticRun(t0=t0, position_km=r0[0], velocity_km_s=v0[0], measurements=tuple(out), truth=states)


__all__ = ["SyntheticRun", "make_run", "entry_state"]

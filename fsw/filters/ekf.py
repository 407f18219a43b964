"""The extended Kalman filters of a bank, held as one stack over the bank's union state layout.

Each filter i has state x_i and covariance P_i over the union layout of the bank
(:mod:`fsw.models.layout`); blocks it does not estimate hold zero state and zero covariance.
All N filters propagate together over the same time grid (one ephemeris lookup per RK stage
for the whole stack) and update together through :func:`fsw.filters.kalman.update`.

Propagation between measurements (t → t'):

* the trajectory and its sensitivity Y = ∂[r, v](t')/∂[r, v, q](t) from the variational
  equations (:mod:`fsw.models.propagator`), assembled into the state transition matrix Φ
  (clock block Φ_c = [[1, h, h²/2], [0, 1, h], [0, 0, 1]], identity for the other parameters);
* P ← Φ P Φᵀ + Q with the clock process noise (:mod:`fsw.models.clock`) and optional white
  acceleration noise on the velocity (SNC: Q_rr = q h³/3, Q_rv = q h²/2, Q_vv = q h);
* at every batch boundary the batched stochastic parameters step as ECRVs (Chaer et al. 1998 eqs.
  25–26; Lubey & Ely 2022 Table 1), the polynomial acceleration coefficients are re-initialised (or,
  with a correlation time, step as ECRVs: Chaer et al. 1998's non-gravitational acceleration); at a
  manoeuvre epoch the planned Δv is added and its execution uncertainty added to P_vv.
  Batches are counted from the bank's initial epoch (the spacecraft schedules its own daily
  ACS activity from the start of the arc) unless ``batch_origin_tdb_s`` says otherwise.

Measurement models live with their kinds (:mod:`fsw.filters.kinds`); the stack gives them the
clock states, the camera models and, for a Doppler count, the state at the count's start
(:meth:`EKFStack.count_start`). A Doppler count needs the state at its start, T before the time
tag; with one measurement per count interval that is exactly where the last propagation leg
began, so the leg's start state and STM serve (no propagation back) — also after a measurement
update at the leg's end, carried to the start through the STM.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from fsw.filters import kalman
from fsw.filters.adaptive_q import AdaptiveQ
from fsw.filters.config import BankConfig, FilterConfig
from fsw.models.environment import Environment
from fsw.models.forces import ForceParameters, srp_coefficient
from fsw.models.layout import StateLayout
from fsw.kernels.count_start import count_start_from_leg
from fsw.kernels.time_update import time_update
from fsw.kernels.joseph_update import joseph_update
from fsw.models.propagator import Propagator
from fsw.models.radiometric import UplinkWork
from fsw.models.stochastic import apply_ecrv_step, batch_boundaries, ecrv_factors

def union_layout(filters: tuple[FilterConfig, ...]) -> StateLayout:
    srp = any(f.srp.scale.bias_sigma > 0 or f.srp.scale.temporal_sigma > 0 for f in filters)
    acs = any(f.acs.magnitude.bias_sigma > 0 or f.acs.magnitude.temporal_sigma > 0 for f in filters)
    degrees = [f.accel.degree for f in filters if f.accel.sigma_km_s2 > 0.0]
    return StateLayout.build(
        srp=srp,
        acs=acs,
        acs_tilt=any(f.acs.direction_sigma_deg > 0 for f in filters),
        poly_degree=degrees[0] if degrees else None,
        clock=max(f.clock.components for f in filters),
        range_bias=any(f.range_bias_sigma_km > 0 for f in filters),
    )


class _Batched:
    """One batched stochastic parameter across the stack: state index and per-filter ECRV data."""

    def __init__(self, index: int, sigma: np.ndarray, length: np.ndarray, tau: list[float | None], origin: float):
        self.index = index
        self.sigma = sigma  # (N,), 0 where the filter does not estimate it
        self.length = length  # (N,)
        self.tau = tau
        self.origin = origin

    def boundaries(self, t0: float, t1: float) -> set[float]:
        out: set[float] = set()
        for i, L in enumerate(self.length):
            if self.sigma[i] > 0.0:
                out.update(batch_boundaries(t0, t1, float(L), self.origin).tolist())
        return out

    def factors(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(m, q) per filter at boundary t: identity step for filters not at a boundary."""
        m = np.ones(len(self.sigma))
        q = np.zeros(len(self.sigma))
        for i, L in enumerate(self.length):
            k = (t - self.origin) / L
            if self.sigma[i] > 0.0 and abs(k - round(k)) * L < 1e-6:
                m[i], q[i] = ecrv_factors(float(L), self.tau[i], float(self.sigma[i]))
        return m, q


class DopplerWork:
    """Arrays a Doppler prediction fills for every count (read before the next one): both ends'
    [r, v] (2, N, 6), their epochs, the start's sensitivity and the light-time solution; for the
    whole-count step (:func:`fsw.filters.radiometric_kinds.doppler_count_step`) also the clock
    phase δ, the prediction h (N, 1) and H (N, 1, n) and R (N, 1, 1)."""

    __slots__ = ("z", "tt", "Yb", "uplinks", "delta", "h", "H", "R")  # slotted: see fsw.executive.FrameExecutive

    def __init__(self, N: int, nq: int, n: int):
        self.z = np.empty((2, N, 6))
        self.tt = np.empty(2)
        self.Yb = np.empty((N, 6, 6 + nq))
        self.uplinks = UplinkWork(2, N)
        self.delta = np.empty(N)
        self.h = np.empty((N, 1))
        self.H = np.empty((N, 1, n))
        self.R = np.empty((N, 1, 1))


class RangeWork:
    """Arrays a range prediction fills for every measurement (read before the next one): the
    filters' [r, v] (1, N, 6) at the reception epoch, that epoch and the light-time solution; for
    the whole-measurement step (:func:`fsw.filters.radiometric_kinds.range_measurement_step`) also
    the clock phase δ, h (N, 1), H (N, 1, n) and R (N, 1, 1)."""

    __slots__ = ("z", "tt", "uplinks", "delta", "h", "H", "R")  # slotted: see fsw.executive.FrameExecutive

    def __init__(self, N: int, n: int):
        self.z = np.empty((1, N, 6))
        self.tt = np.empty(1)
        self.uplinks = UplinkWork(1, N)
        self.delta = np.empty(N)
        self.h = np.empty((N, 1))
        self.H = np.empty((N, 1, n))
        self.R = np.empty((N, 1, 1))


class OpticalWork:
    """Arrays the compiled optical step (:func:`fsw.filters.optical_kind.optical_image_step`) fills
    for every image (read before the next one): the lines of sight g and velocities v (N, 3),
    h (N, 2), the partials Hr, Hv (N, 2, 3), H (N, 2, n) and R (N, 2, 2)."""

    __slots__ = ("g", "v", "h", "Hr", "Hv", "H", "R")  # slotted: see fsw.executive.FrameExecutive

    def __init__(self, N: int, n: int):
        self.g = np.empty((N, 3))
        self.v = np.empty((N, 3))
        self.h = np.empty((N, 2))
        self.Hr = np.empty((N, 2, 3))
        self.Hv = np.empty((N, 2, 3))
        self.H = np.empty((N, 2, n))
        self.R = np.empty((N, 2, 2))


class EKFStack:
    """N extended Kalman filters on a common union layout, propagated and updated together."""

    # slotted: see fsw.executive.FrameExecutive
    __slots__ = ("config", "names", "layout", "env", "t", "x", "present", "P", "batch_origin", "forces",
                 "propagator", "_q_cols", "_z_to_state", "_state_to_q", "driver_columns", "_driver_pairs",
                 "_clock", "_q_known", "_phi_source", "batched", "clock_q", "snc_psd", "_last_leg", "maneuvers",
                 "_next_event", "_event_horizon", "adaptive_q", "_any_adaptive", "_no_gate", "doppler_work",
                 "range_work", "optical_work", "_camera_arrays")

    def __init__(self, config: BankConfig, t0: float, r0: ArrayLike, v0: ArrayLike, env: Environment | None = None):
        self.config = config
        cfgs = config.filters
        self.names = tuple(f.name for f in cfgs)
        N = len(cfgs)
        self.layout = L = union_layout(cfgs)
        self.env = env if env is not None else Environment()
        n = L.n
        self.t = float(t0)
        r = np.asarray(r0, dtype=float)
        v = np.asarray(v0, dtype=float)
        if r.shape != (3,) or v.shape != (3,) or not (np.all(np.isfinite(r)) and np.all(np.isfinite(v))):
            raise ValueError("initial position and velocity must be finite 3-vectors")

        sig = np.zeros((N, n))
        self.x = np.zeros((N, n))
        self.x[:, 0:3] = r
        self.x[:, 3:6] = v
        for i, f in enumerate(cfgs):
            sig[i, 0:3] = f.position_sigma_km
            sig[i, 3:6] = f.velocity_sigma_km_s
            if L.has("srp_bias"):
                sig[i, L.slices["srp_bias"]] = f.srp.scale.bias_sigma
                sig[i, L.slices["srp_stoch"]] = f.srp.scale.temporal_sigma
            if L.has("acs_bias"):
                sig[i, L.slices["acs_bias"]] = f.acs.magnitude.bias_sigma
                sig[i, L.slices["acs_stoch"]] = f.acs.magnitude.temporal_sigma
            if L.has("acs_tilt"):
                sig[i, L.slices["acs_tilt"]] = math.radians(f.acs.direction_sigma_deg)
            if L.has("accel"):
                sig[i, L.slices["accel"]] = f.accel.sigma_km_s2
            if L.has("clock"):
                k = f.clock.components
                c = L.slices["clock"].start
                sig[i, c : c + k] = (f.clock.phase_sigma_s, f.clock.frequency_sigma, f.clock.drift_sigma_per_s)[:k]
                if k == 3:
                    self.x[i, c + 2] = f.clock.drift_per_s
            if L.has("range_bias"):
                sig[i, L.slices["range_bias"]] = f.range_bias_sigma_km
        self.present = sig > 0.0
        self.P = np.zeros((N, n, n))
        self.P[:, np.arange(n), np.arange(n)] = sig**2

        origin = self.t if config.batch_origin_tdb_s is None else float(config.batch_origin_tdb_s)
        self.batch_origin = origin
        self.forces = ForceParameters(
            srp_coefficient=np.array([srp_coefficient(f.srp.area_m2, f.srp.mass_kg, f.srp.cr) for f in cfgs]),
            acs_nominal=np.array([f.acs.nominal_km_s2 for f in cfgs]),
            acs_direction=np.array([np.asarray(f.acs.direction_body) / np.linalg.norm(f.acs.direction_body) for f in cfgs]),
            poly_degree=L.poly_degree,
            poly_batch_s=np.array([f.accel.batch_length_s for f in cfgs]),
            poly_origin_s=origin,
        )
        self.propagator = Propagator(self.env, self.forces, config.step_fraction, config.max_step_s)
        self._q_cols = L.q_columns
        nq = L.n_q
        # [z, q] → state columns, and state → q: Φ's dynamics rows are Y @ _Z_TO_STATE
        self._z_to_state = np.zeros((6 + nq, n))
        self._z_to_state[np.arange(6), np.arange(6)] = 1.0
        self._state_to_q = np.zeros((n, nq))
        for col, qi in self._q_cols:
            self._z_to_state[6 + qi, col] = 1.0
            self._state_to_q[col, qi] = 1.0
        # q by column picks: each driver is fed by one or two state columns, and the sum of two
        # (the rest of x @ _state_to_q is exact zeros) is the same in any order
        feeds: list[list[int]] = [[] for _ in range(nq)]
        for col, qi in self._q_cols:
            feeds[qi].append(col)
        #: the picks as columns: driver j is x[:, first[j]] (+ x[:, second[j]] where second[j] ≥ 0);
        #: empty where a driver has more feeds (q is then x @ _state_to_q). The compiled steps write
        #: the drivers of the state they update with them (``fsw.kernels.leg.drivers_into``).
        self.driver_columns: tuple[np.ndarray, np.ndarray] = (np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))
        self._driver_pairs = (np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))  # (j, second[j]) with two feeds
        if nq > 0 and all(1 <= len(f) <= 2 for f in feeds):
            self.driver_columns = (np.array([f[0] for f in feeds], dtype=np.int64),
                                   np.array([f[1] if len(f) == 2 else -1 for f in feeds], dtype=np.int64))
            pairs = [qi for qi in range(nq) if len(feeds[qi]) == 2]
            self._driver_pairs = (np.array(pairs, dtype=np.int64), np.array([feeds[qi][1] for qi in pairs], dtype=np.int64))
        self._clock = (L.slices["clock"].start, L.slices["clock"].stop) if L.has("clock") else None
        # the drivers of a state array the stack made and has not written since: the time update
        # copies the parameter columns, so its output has its input's q
        self._q_known: tuple[np.ndarray | None, np.ndarray] = (None, np.empty((N, nq)))
        # the column of Y that feeds each state column of Φ's dynamics rows (−1: none)
        self._phi_source = np.full(n, -1, dtype=np.int64)
        self._phi_source[0:6] = np.arange(6)
        for col, qi in self._q_cols:
            self._phi_source[col] = 6 + qi
        self.batched: list[_Batched] = []
        if L.has("srp_stoch"):
            self.batched.append(_Batched(L.slices["srp_stoch"].start,
                                         np.array([f.srp.scale.temporal_sigma for f in cfgs]),
                                         np.array([f.srp.scale.batch_length_s for f in cfgs]),
                                         [f.srp.scale.correlation_time_s for f in cfgs], origin))
        if L.has("acs_stoch"):
            self.batched.append(_Batched(L.slices["acs_stoch"].start,
                                         np.array([f.acs.magnitude.temporal_sigma for f in cfgs]),
                                         np.array([f.acs.magnitude.batch_length_s for f in cfgs]),
                                         [f.acs.magnitude.correlation_time_s for f in cfgs], origin))
        if L.has("accel"):
            s = L.slices["accel"]
            for idx in range(s.start, s.stop):
                self.batched.append(_Batched(idx, np.array([f.accel.sigma_km_s2 for f in cfgs]),
                                             np.array([f.accel.batch_length_s for f in cfgs]),
                                             [f.accel.correlation_time_s for f in cfgs], origin))
        self.clock_q = np.zeros((N, 3))
        for i, f in enumerate(cfgs):
            k = f.clock.components
            self.clock_q[i, :k] = (f.clock.q_white_fm_s, f.clock.q_random_walk_fm_per_s, f.clock.q_random_run_per_s3)[:k]
        self.snc_psd = np.array([f.velocity_noise_psd_km2_s3 for f in cfgs])
        # the last propagation leg (t0, t1, z(t0), z(t1), q, Y): a Doppler count interval that is
        # exactly this leg reuses it instead of propagating back
        self._last_leg: tuple[float, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self.maneuvers = sorted(config.maneuvers, key=lambda m: m.epoch_tdb_s)
        self._next_event = -math.inf  # no batch boundary or manoeuvre before this epoch
        self._event_horizon = self.t
        # per-filter eq. 1 process noise from the state residuals (None: fixed process noise)
        self.adaptive_q: list[AdaptiveQ | None] = [
            AdaptiveQ(f.process_noise) if f.process_noise.mode != "fixed" else None for f in cfgs
        ]
        self._any_adaptive = any(aq is not None for aq in self.adaptive_q)
        self._no_gate = np.full(N, np.inf)
        self.doppler_work = DopplerWork(N, nq, L.n)
        self.range_work = RangeWork(N, L.n)
        self.optical_work = OpticalWork(N, L.n)
        #: made on first use (:attr:`cameras`)
        self._camera_arrays: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    # -- propagation ----------------------------------------------------------------------------
    def drivers(self, x: np.ndarray | None = None) -> np.ndarray:
        """Acceleration drivers q (N, n_q) of the state: SRP scale, ACS magnitude and tilts, polynomial."""
        x = self.x if x is None else x
        first = self.driver_columns[0]
        if first.size == 0:
            return np.ascontiguousarray(x @ self._state_to_q)
        q = np.ascontiguousarray(x[:, first])  # the kernels take q C-ordered; x[:, cols] is not
        pairs, second = self._driver_pairs
        if pairs.size:
            q[:, pairs] += x[:, second]
        return q

    def _propagate_interval(self, t1: float) -> None:
        h = t1 - self.t
        if h == 0.0:
            return
        x = self.x
        if not x.flags.c_contiguous:
            x = np.ascontiguousarray(x)
        known, q = self._q_known
        if known is not x:
            q = self.drivers(x)
        N, n = x.shape
        z1 = x[:, 0:6].copy()
        Y = np.empty((N, 6, 6 + q.shape[1]))
        self.propagator.propagate_z(self.t, t1, z1, q, Y)
        c0, c1 = self._clock if self._clock is not None else (0, 0)
        x_new = np.empty((N, n))
        P = np.empty((N, n, n))
        P_prior = self.P if self.P.flags.c_contiguous else np.ascontiguousarray(self.P)
        time_update(x, z1, P_prior, Y, self._phi_source, c0, c1, h, self.clock_q, self.snc_psd, x_new, P)
        self.end_leg(t1, x, z1, q, Y, x_new, P)

    def plain_leg(self, t1: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(x, P, q) to fly the next leg to t1 with the kernels directly, when it is a plain one:
        forward, crossing no batch boundary or manoeuvre, with fixed process noise and C-ordered
        arrays. None otherwise (:meth:`propagate_to` then handles it)."""
        if not (self.t < t1 < self._next_event and t1 <= self._event_horizon) or self._any_adaptive:
            return None
        x, P = self.x, self.P
        if not (x.flags.c_contiguous and P.flags.c_contiguous):
            return None
        known, q = self._q_known
        return x, P, (q if known is x else self.drivers(x))

    def plain_flight(self, t1: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, float, float],
                                                np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """What a compiled step needs to fly the leg to t1 when it is a plain one
        (:meth:`plain_leg`): x, P, the drivers q, the leg's ephemeris table (as
        ``Propagator.table``) and new arrays for its results z1 (N, 6), Y (N, 6, 6 + n_q),
        x (N, n), P (N, n, n) — new, since x and P become the bank's state (:meth:`end_leg`).
        None otherwise."""
        leg = self.plain_leg(t1)
        if leg is None:
            return None
        x, P, q = leg
        N, n = x.shape
        return (x, P, q, self.propagator.table(self.t, t1),
                np.empty((N, 6)), np.empty((N, 6, 6 + q.shape[1])), np.empty((N, n)), np.empty((N, n, n)))

    def take_update(self, x: np.ndarray, P: np.ndarray, q: np.ndarray) -> None:
        """Take the state a compiled step's update made, with the drivers it wrote of it
        (``q``, read only where :attr:`driver_columns` are not empty)."""
        self.x = x
        self.P = P
        if self.driver_columns[0].size:
            self._q_known = (x, q)

    def end_leg(self, t1: float, x0: np.ndarray, z1: np.ndarray, q: np.ndarray, Y: np.ndarray, x1: np.ndarray,
                P1: np.ndarray) -> None:
        """Take the state x1, P1 at t1 that a leg from the current epoch reached, flown with drivers
        q from the state x0, and remember the leg (end [r, v] z1, sensitivity Y) for a Doppler
        count over it (:meth:`count_start`)."""
        # x0 is no longer the stack's state and nothing else writes it: it serves as the leg's start
        self._last_leg = (self.t, t1, x0, z1, q, Y)
        self._q_known = (x1, q)
        self.x = x1
        self.P = P1
        self.t = t1

    def _events(self, t1: float) -> list[float]:
        events: set[float] = set()
        for b in self.batched:
            events |= b.boundaries(self.t, t1)
        events |= {m.epoch_tdb_s for m in self.maneuvers if self.t < m.epoch_tdb_s <= t1}
        return sorted(events)

    def _apply_events(self, t: float) -> None:
        self._last_leg = None
        self._q_known = (None, self._q_known[1])  # x is written in place below
        for b in self.batched:
            m, q = b.factors(t)
            if np.any(q > 0.0) or np.any(m != 1.0):
                apply_ecrv_step(self.x, self.P, b.index, m, q)
        for man in self.maneuvers:
            if man.epoch_tdb_s == t:
                dv = np.asarray(man.dv_km_s)
                self.x[:, 3:6] += dv
                var = man.sigma_km_s**2 + (man.sigma_rel * float(np.linalg.norm(dv))) ** 2
                self.P[:, [3, 4, 5], [3, 4, 5]] += var

    def propagate_to(self, t1: float) -> None:
        """Advance every filter to t1 (≥ current epoch), stepping batch boundaries and manoeuvres."""
        t1 = float(t1)
        if not math.isfinite(t1) or t1 < self.t:
            raise ValueError(f"cannot propagate from {self.t} back to {t1}")
        t_start = self.t
        self._propagate_events(t1)
        if not self._any_adaptive:
            return
        for i, aq in enumerate(self.adaptive_q):
            if aq is not None and aq.active and t1 > t_start:
                q = aq.q_diagonal(t1 - t_start)
                self.P[i, np.arange(6), np.arange(6)] += q

    def _propagate_events(self, t1: float) -> None:
        if t1 >= self._next_event or t1 > self._event_horizon:
            # batch boundaries and manoeuvres are looked up a day ahead at a time
            horizon = max(t1, self.t + 86400.0)
            events = self._events(horizon)
            self._next_event = events[0] if events else math.inf
            self._event_horizon = horizon
            for te in events:
                if te > t1:
                    break
                self._propagate_interval(te)
                self._apply_events(te)
            if self._next_event <= t1:
                rest = [te for te in events if te > t1]
                self._next_event = rest[0] if rest else math.inf
        self._propagate_interval(t1)

    @property
    def any_adaptive(self) -> bool:
        """Whether any filter adapts its process noise (:mod:`fsw.filters.adaptive_q`)."""
        return self._any_adaptive

    # -- what the measurement models read -------------------------------------------------------
    @property
    def clock_columns(self) -> tuple[int, int] | None:
        """[start, stop) of the clock block in the union layout (None: no clock states)."""
        return self._clock

    @property
    def state_sources(self) -> np.ndarray:
        """(n,) int: the column of [r, v, q] that drives each state column (−1: none; the clock
        and range bias) — :attr:`z_to_state` as an index map."""
        return self._phi_source

    @property
    def z_to_state(self) -> np.ndarray:
        """(6 + n_q, n): maps the dynamics sensitivity columns [r, v, q] onto state columns."""
        return self._z_to_state

    def clock_state(self, x: np.ndarray, k: int) -> np.ndarray:
        """Clock component k (0 phase, 1 frequency, 2 drift) of every filter; 0 where absent."""
        if self._clock is None or self._clock[1] - self._clock[0] <= k:
            return np.zeros(x.shape[0])
        return x[:, self._clock[0] + k]

    def count_start(self, t: float, count_s: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """[r, v] at t − T and its sensitivity Yb = ∂[r, v](t − T)/∂[r, v, q](t).

        If the last propagation leg ran from t − T to the current epoch, its start serves: the
        leg's STM [Φ | Ψ] maps start to end, so Yb = [Φ⁻¹, −Φ⁻¹Ψ], and any change of the
        state at t since the leg was flown (a measurement update at t) carries to the start
        through Yb (the flow over T is linear to ~1e-15 km in such corrections). Φ is
        symplectic (a Hamiltonian flow: G is symmetric), so Φ⁻¹ = [[Φ_vvᵀ, −Φ_rvᵀ], [−Φ_vrᵀ, Φ_rrᵀ]].
        Otherwise the state is propagated back by T.
        """
        z_start = np.empty((x.shape[0], 6))
        Yb = self.count_start_into(t, count_s, x, z_start)
        return z_start[:, 0:3], z_start[:, 3:6], Yb

    def count_start_into(self, t: float, count_s: float, x: np.ndarray, z_start: np.ndarray,
                         Yb: np.ndarray | None = None) -> np.ndarray:
        """:meth:`count_start` writing [r, v] at t − T into ``z_start`` (N, 6), C-contiguous, and Yb
        into ``Yb`` (N, 6, 6 + n_q) if given; returns Yb."""
        leg = self._last_leg
        xc = x if x.flags.c_contiguous else np.ascontiguousarray(x)
        known, q = self._q_known
        if known is not xc:
            q = self.drivers(xc)
            if xc is self.x:
                self._q_known = (xc, q)
        if self._count_spans_leg(x, t, count_s):
            _, _, x0, z1, q_leg, Y = leg  # type: ignore[misc]
            if Yb is None or Yb.shape != Y.shape:
                Yb = np.empty(Y.shape)
            # the kernel reads the first six columns of the states x0 and x
            count_start_from_leg(Y, x0, z1, xc, q, q_leg, z_start, Yb)
            return Yb
        z_start[:] = xc[:, 0:6]
        if Yb is None:
            Yb = np.empty((x.shape[0], 6, 6 + q.shape[1]))
        self.propagator.propagate_z(t, t - count_s, z_start, q, Yb)
        return Yb

    def _count_spans_leg(self, x: np.ndarray, t: float, count_s: float) -> bool:
        """Whether a count of T = ``count_s`` ending at t, for the stack's own states x, spans the
        last leg (so the leg's STM gives its start)."""
        leg = self._last_leg
        return leg is not None and x is self.x and leg[1] == self.t == t and abs(leg[0] - (t - count_s)) < 1e-6

    def at_epoch(self, t: float) -> bool:
        """Whether a measurement at t needs no leg flown first — t is the current epoch and no
        event is due (:meth:`propagate_to` t would change nothing) — and updates plainly: fixed
        process noise, C-ordered arrays (what a compiled step then updates in place of
        :meth:`update`)."""
        return (t == self.t and t < self._next_event and t <= self._event_horizon and not self._any_adaptive
                and self.x.flags.c_contiguous and self.P.flags.c_contiguous)

    def held_leg(self, t: float, count_s: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """For a count of T = ``count_s`` ending at the current epoch t, when nothing is to be flown
        first (:meth:`propagate_to` t would change nothing) and the count spans the last leg: that
        leg's start state, end [r, v], drivers and sensitivity, and the current state's drivers
        (x0, z1, q_leg, Y, q), as :meth:`count_start` uses them. None otherwise."""
        if not (t == self.t and t < self._next_event and t <= self._event_horizon) or self._any_adaptive:
            return None
        x = self.x
        if not (x.flags.c_contiguous and self.P.flags.c_contiguous) or not self._count_spans_leg(x, t, count_s):
            return None
        _, _, x0, z1, q_leg, Y = self._last_leg  # type: ignore[misc]
        return x0, z1, q_leg, Y, self.state_drivers()

    def state_drivers(self) -> np.ndarray:
        """The drivers q of the current state x (:meth:`drivers`), kept with it until x changes."""
        x = self.x
        known, q = self._q_known
        if known is not x:
            q = self.drivers(x)
            self._q_known = (x, q)
        return q

    @property
    def cameras(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per-filter camera model: focal length [px], principal point [px], light-time and
        aberration flags (the arguments of :func:`fsw.models.optical.optical`)."""
        cached = self._camera_arrays
        if cached is None:
            cams = [f.camera for f in self.config.filters]
            cached = (np.array([c.focal_px for c in cams]), np.array([c.principal_point_px for c in cams]),
                      np.array([c.light_time for c in cams]), np.array([c.aberration for c in cams]))
            self._camera_arrays = cached
        return cached

    # -- update ---------------------------------------------------------------------------------
    def update(self, y: np.ndarray, h: np.ndarray, H: np.ndarray, R: np.ndarray, does: np.ndarray,
               gate: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Joseph-form update of every filter where ``does``; returns (residual, S, chi2, processed).

        m ≤ 2 (every kind but a general vector measurement) runs the compiled kernel
        (:mod:`fsw.kernels.joseph_update`), larger m :func:`kalman.update`: the same arithmetic."""
        N, n = self.x.shape
        m = H.shape[1]
        if m > 2:
            return self._update_numpy(y[None, :] - h, H, R, does, gate)
        if y.shape != (m,) or h.shape != (N, m):  # the kernel reads them without bounds checks
            raise ValueError(f"measurement {y.shape} and predictions {h.shape} do not match H {H.shape}")
        if not (y.dtype == np.float64 and y.flags.c_contiguous):
            y = np.ascontiguousarray(y, dtype=float)
        if not (h.dtype == np.float64 and h.flags.c_contiguous):
            h = np.ascontiguousarray(h, dtype=float)
        residual = np.empty((N, m))  # y − h, formed by the kernel
        x_new = np.empty((N, n))
        P_new = np.empty((N, n, n))
        S = np.empty((N, m, m))
        chi2 = np.empty(N)
        processed = np.empty(N, dtype=bool)
        P = self.P if self.P.flags.c_contiguous else np.ascontiguousarray(self.P)
        joseph_update(self.x, P, H if H.flags.c_contiguous else np.ascontiguousarray(H),
                      R if R.flags.c_contiguous else np.ascontiguousarray(R), y, h, does,
                      self._no_gate if gate is None else gate, residual, x_new, P_new, S, chi2, processed)
        # P⁺ carries only the rounding asymmetry of one update: the next propagation step
        # symmetrises it, so it never accumulates
        if self._any_adaptive:
            for i, aq in enumerate(self.adaptive_q):
                if aq is not None and processed[i]:
                    aq.add(self.t, x_new[i, 0:6] - self.x[i, 0:6])
        self.x = x_new
        self.P = P_new
        return residual, S, chi2, processed

    def _update_numpy(self, residual: np.ndarray, H: np.ndarray, R: np.ndarray, does: np.ndarray,
                      gate: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        n = self.layout.n
        x_prior = self.x.copy() if self._any_adaptive else self.x
        Mt = kalman.augmented_joint(self.x, self.P, H, R, residual)
        PX, res, S, chi2, processed = kalman.update(Mt, n, does, gate)
        processed = does if processed is None else processed
        if processed.all():
            self.x = -PX[:, :, n]
            self.P = np.ascontiguousarray(PX[:, :, :n])
        elif processed.any():
            self._q_known = (None, self._q_known[1])
            self.x[processed] = -PX[processed, :, n]
            self.P[processed] = PX[processed, :, :n]
        for i, aq in enumerate(self.adaptive_q if self._any_adaptive else ()):
            if aq is not None and processed[i]:
                aq.add(self.t, self.x[i, 0:6] - x_prior[i, 0:6])
        return res.copy(), S.copy(), chi2, processed

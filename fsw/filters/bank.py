"""The onboard filter bank: N EKFs fed the same measurements, one ``BankRecord`` per measurement.

For every measurement j the bank propagates all filters to the time tag, predicts the
measurement with every filter — including filters that do not process that kind, because the
gating networks need z̄_ij = y_j − h_ij(x̄_ij) and S_ij = R_ij + H̃_ij P̄_ij H̃_ijᵀ for all of them
(Lubey & Ely 2022 eq. 5, §3.2) — and updates the filters that process it. Outputs: the record, each
filter's estimate, the weighted-sum estimate x̂_opt = Σ p_i x̂_i (Chaer et al. 1997 eq. 3) and the
best-filter estimate (Lubey & Ely 2022 §2).

A measurement the bank cannot use (NaN, unknown kind or source, wrong size, time running
backwards, ...) raises :class:`MeasurementRejected` before any filter state is touched and is
counted in ``bank.rejected`` by reason.

Measurement noise R is the reported sigma (times the filter's ``sigma_scale``) squared, plus
whatever variance the kind's model adds (a one-way Doppler count: the onboard clock's own
short-term instability over the count). What each kind is screened for and how it is predicted
is its model's business (:mod:`fsw.filters.kinds`); the bank names no kind.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
from numpy.typing import ArrayLike

from fsw.filters import kinds
from fsw.filters.combine import best_index, normalised_weights
from fsw.filters.adaptive_q import AdaptiveQCounters
from fsw.filters.config import BankConfig
from fsw.filters.ekf import EKFStack
from fsw.filters.estimate import FilterEstimate
from fsw.filters.errors import MeasurementRejected, UnknownFilter
from fsw.filters.kind_model import KindModel
from fsw.filters.record import BankRecord
from fsw.filters.validate import screen
from fsw.interface.messages import Measurement
from fsw.kernels.mixture_estimate import mixture_estimate
from fsw.models.environment import Environment
from fsw.models.optical import GeometryError


_EYES = {m: np.eye(m) for m in range(1, 7)}


class FilterBank:
    """A bank of extended Kalman filters (see the module docstring)."""

    # slotted: see fsw.executive.FrameExecutive
    __slots__ = ("config", "stack", "names", "active", "rejected", "processed_count", "_process_masks",
                 "_sigma_scale", "_gate", "_gate_or_none", "_layouts", "_selections")

    KINDS: tuple[str, ...] = kinds.FILTER_KINDS
    #: Time tags may run backwards by this much (onboard-clock jitter between measurements,
    #: a first measurement tagged a clock error before the initial epoch); such a measurement
    #: is processed at the bank epoch (≤ 0.5 m of motion). Anything earlier is refused.
    TIME_TOLERANCE_S = 1e-4

    def __init__(self, config: BankConfig, t0: float, position_km: ArrayLike, velocity_km_s: ArrayLike,
                 env: Environment | None = None):
        self.config = config
        self.stack = EKFStack(config, t0, position_km, velocity_km_s, env)
        self.names = self.stack.names
        self.active = np.ones(len(self.names), dtype=bool)
        self.rejected: Counter[str] = Counter()
        self.processed_count = 0
        self._process_masks = {k: np.array([k in f.processes for f in config.filters]) for k in self.KINDS}
        self._sigma_scale = {k: np.array([f.sigma_scale.get(k, 1.0) for f in config.filters], dtype=float)
                             for k in self.KINDS}
        self._gate = np.array([np.inf if f.gate_chi2 is None else f.gate_chi2 for f in config.filters], dtype=float)
        self._gate_or_none = self._gates()
        # each filter's columns of the union state (fixed: a state cannot be added at run time)
        self._layouts = [(tuple(self.state_names[c] for c in cols.tolist()), cols, bool(keep.all()))
                         for keep, cols in ((k, np.flatnonzero(k)) for k in self.stack.present)]
        #: the combined estimate's selection per set of weighted filters (:meth:`_combined_selection`)
        self._selections: dict[bytes, tuple[tuple[str, ...], np.ndarray, np.ndarray]] = {}

    # -- introspection -------------------------------------------------------------------------
    @property
    def t(self) -> float:
        return self.stack.t

    @property
    def size(self) -> int:
        return len(self.names)

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the union state (every filter's arrays are subsets of it)."""
        return self.stack.layout.names

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise UnknownFilter(name) from None

    def filter(self, name: str) -> FilterEstimate:
        """Estimate of one filter, in its own layout (blocks it does not estimate left out)."""
        return self._estimate_of(self.index(name), name)

    def _estimate_of(self, i: int, name: str) -> FilterEstimate:
        names, cols, full = self._layouts[i]
        st = self.stack
        if full:
            return FilterEstimate(name, self.t, names, st.x[i].copy(), st.P[i].copy())
        return FilterEstimate(name, self.t, names, st.x[i, cols], st.P[i][cols[:, None], cols])

    def x(self, name: str) -> np.ndarray:
        return self.filter(name).x

    def P(self, name: str) -> np.ndarray:
        return self.filter(name).P

    def position_sigma_km(self, name: str) -> float:
        """RTPC of one filter."""
        i = self.index(name)
        return float(math.sqrt(np.trace(self.stack.P[i, 0:3, 0:3])))

    # -- adaptive process noise ----------------------------------------------------------------
    def adaptive_lp_cost(self) -> float:
        """Declared work units of the enabled filters' FLR slope fits in one update (Garhwal et al.;
        :meth:`fsw.filters.adaptive_q.AdaptiveQ.declared_cost`); 0 without fuzzy-adaptive filters."""
        if not self.stack.any_adaptive:
            return 0.0  # asked per measurement
        return float(sum(aq.declared_cost() for aq, on in zip(self.stack.adaptive_q, self.active)
                         if aq is not None and on))

    def adaptive_counts(self) -> dict[str, int]:
        """The adaptive process-noise counters summed over the bank; empty without adaptive filters."""
        total = AdaptiveQCounters()
        present = False
        for aq in self.stack.adaptive_q:
            if aq is not None:
                total.add(aq.counters)
                present = True
        return total.as_counts() if present else {}

    # -- commands ------------------------------------------------------------------------------
    def set_enabled(self, name: str, enabled: bool) -> None:
        """Enable/disable a filter. A disabled filter is still propagated (so it can be
        re-enabled at once) and still predicts, but does not update, and is marked inactive."""
        self.active[self.index(name)] = bool(enabled)

    def set_param(self, name: str, param: str, value: float) -> None:
        """Change a filter's noise parameters at run time.

        ``sigma_scale.<kind>`` (R multiplier on the reported sigma), ``velocity_noise_psd``
        (km²/s³), ``gate_chi2`` (≤ 0: editing off), ``srp.temporal_sigma``,
        ``acs.temporal_sigma``, ``accel.sigma`` (km/s², from the next batch on),
        ``clock.q_white_fm``, ``clock.q_random_walk_fm``, ``clock.q_random_run``.
        """
        i = self.index(name)
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{param}: value must be finite")
        st = self.stack
        L = st.layout
        if param.startswith("sigma_scale."):
            kind = param.split(".", 1)[1]
            if kind not in self._sigma_scale or value <= 0.0:
                raise ValueError(f"{param}: unknown kind or non-positive scale")
            self._sigma_scale[kind][i] = value
        elif param == "velocity_noise_psd":
            if value < 0.0:
                raise ValueError(f"{param} must be >= 0")
            st.snc_psd[i] = value
        elif param == "gate_chi2":
            self._gate[i] = value if value > 0.0 else np.inf
            self._gate_or_none = self._gates()
        elif param in ("srp.temporal_sigma", "acs.temporal_sigma", "accel.sigma"):
            block = {"srp.temporal_sigma": "srp_stoch", "acs.temporal_sigma": "acs_stoch", "accel.sigma": "accel"}[param]
            if not L.has(block) or value < 0.0:
                raise ValueError(f"{param}: block {block} not in this bank, or negative value")
            cols = range(L.slices[block].start, L.slices[block].stop)
            if not all(st.present[i, c] for c in cols) or value == 0.0:
                raise ValueError(f"{param}: filter {name} does not estimate {block} (a state cannot be added or removed at run time)")
            for b in st.batched:
                if b.index in cols:
                    b.sigma[i] = value
        elif param.startswith("clock."):
            k = {"clock.q_white_fm": 0, "clock.q_random_walk_fm": 1, "clock.q_random_run": 2}.get(param)
            if k is None or value < 0.0:
                raise ValueError(f"unknown parameter {param!r} or negative value")
            if not L.has("clock") or not st.present[i, L.slices["clock"].start + k]:
                raise ValueError(f"{param}: filter {name} has no such clock state")
            st.clock_q[i, k] = value
        else:
            raise ValueError(f"unknown parameter {param!r}")

    def processes(self, name: str, kind: str) -> bool:
        """Whether filter ``name`` updates with measurements of ``kind``."""
        mask = self._process_masks.get(kind)
        return bool(mask is not None and mask[self.index(name)])

    #: Parameters :meth:`get_param` reads (what parameter adaptation may tune).
    TUNABLE_PREFIXES = ("sigma_scale.", "velocity_noise_psd", "clock.q_")

    def get_param(self, name: str, param: str) -> float:
        """Current value of a noise parameter :meth:`set_param` sets (``sigma_scale.<kind>``,
        ``velocity_noise_psd``, ``clock.q_white_fm``, ``clock.q_random_walk_fm``, ``clock.q_random_run``)."""
        i = self.index(name)
        if param.startswith("sigma_scale."):
            kind = param.split(".", 1)[1]
            if kind not in self._sigma_scale:
                raise ValueError(f"{param}: unknown kind")
            return float(self._sigma_scale[kind][i])
        if param == "velocity_noise_psd":
            return float(self.stack.snc_psd[i])
        k = {"clock.q_white_fm": 0, "clock.q_random_walk_fm": 1, "clock.q_random_run": 2}.get(param)
        if k is None:
            raise ValueError(f"parameter {param!r} cannot be read")
        return float(self.stack.clock_q[i, k])

    # -- processing ----------------------------------------------------------------------------
    def _screen(self, meas: Measurement) -> tuple[np.ndarray, np.ndarray, float, KindModel]:
        """(value, sigma, time tag, the kind's model) of a measurement the bank can use, else
        :class:`MeasurementRejected`."""
        value, sigma = screen(meas, kinds.DIMENSIONS)
        t = float(meas.t_s)
        stack = self.stack
        if t < stack.t - self.TIME_TOLERANCE_S:
            raise MeasurementRejected("out_of_order", f"time tag {t} is before the bank epoch {stack.t}")
        env = stack.env
        if not env.covers(t):
            raise MeasurementRejected("out_of_range", f"time tag {t} is outside the onboard ephemeris")
        model = kinds.REGISTRY[meas.kind]  # screen() accepted the kind: the bank has its model
        model.screen(meas, env)
        return value, sigma, t, model

    def predict(self, meas: Measurement, x: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """h (N, m) and H (N, m, n) of a (screened) measurement at the current bank epoch."""
        st = self.stack
        return kinds.model(meas.kind).predict(st, meas, st.t, st.x if x is None else x)

    def process(self, meas: Measurement) -> BankRecord:
        """Propagate to the measurement, predict it with every filter, update the filters
        that process its kind, and return the record for the gating networks."""
        try:
            value, sigma, t, model = self._screen(meas)
        except MeasurementRejected as exc:
            self.rejected[exc.reason] += 1
            raise
        kind = meas.kind
        stack = self.stack
        t1 = t if t > stack.t else stack.t
        does = self._process_masks[kind] & self.active
        done = model.step(stack, meas, t1, value, sigma, self._sigma_scale[kind], does, self._gate)
        if done is None:
            residual, S, chi2, processed = self._steps(meas, model, t1, value, sigma, does)
        else:
            residual, S, chi2, processed = done
        self.processed_count += 1
        # by position (BankRecord's field order), one record per measurement
        return BankRecord(t, int(meas.seq), str(kind), self.names, residual, S, chi2, processed.copy(),
                          self.active.copy())

    def _steps(self, meas: Measurement, model: KindModel, t1: float, value: np.ndarray, sigma: np.ndarray,
               does: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Propagation, prediction and update one after the other (what ``model.step`` does in one
        call where it can)."""
        self.stack.propagate_to(t1)
        try:
            h, H = self.predict(meas)
        except GeometryError as exc:
            # only propagation (which any later measurement would do) has happened
            self.rejected["geometry"] += 1
            raise MeasurementRejected("geometry", str(exc)) from None
        var = self._sigma_scale[meas.kind][:, None] * sigma  # (N, m) per-filter sigmas
        var *= var
        added = model.added_variance(self.stack, meas)
        if added is not None:
            var += added[:, None]
        m = sigma.size
        R = var[:, :, None] if m == 1 else var[:, :, None] * (_EYES[m] if m in _EYES else np.eye(m))
        return self.stack.update(value, h, H, R, does, self._gate_or_none)

    def _gates(self) -> np.ndarray | None:
        """The per-filter gates, None while no filter edits (kept in ``_gate_or_none``, read per
        measurement, rewritten where a telecommand sets a gate)."""
        return None if bool(np.isinf(self._gate).all()) else self._gate

    def propagate_to(self, t: float) -> None:
        """Advance every filter to t without a measurement (e.g. for an estimate output)."""
        self.stack.propagate_to(t)

    # -- outputs -------------------------------------------------------------------------------
    def _combined_selection(self, used: np.ndarray) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
        """The combined estimate's state names, and the indices of the filters it combines (``used``)
        and of the states they all estimate; kept per ``used`` (the filters present in a state never
        change, and the set of filters with weight rarely does)."""
        cache = self._selections
        key = used.tobytes()
        hit = cache.get(key)
        if hit is None:
            common = np.all(self.stack.present[used], axis=0)
            if len(cache) >= 64:  # a bank of N filters has 2^N subsets: keep the recent ones
                cache.clear()
            hit = cache[key] = (tuple(n for n, k in zip(self.state_names, common) if k), np.flatnonzero(used),
                                np.flatnonzero(common))
        return hit

    def estimates(self, weights: ArrayLike | None = None) -> dict[str, FilterEstimate]:
        """Every filter's estimate; with gating ``weights`` also 'combined' (weighted sum over
        the states all contributing filters estimate, mixture covariance) and 'best'."""
        out = {name: self._estimate_of(i, name) for i, name in enumerate(self.names)}
        if weights is None:
            return out
        w = normalised_weights(np.asarray(weights, dtype=float), self.active)
        names, rows, cols = self._combined_selection(w > 0.0)
        # the contributing filters' common states, gathered inside the kernel
        st = self.stack
        x_opt, P_opt = np.empty(cols.size), np.empty((cols.size, cols.size))
        mixture_estimate(np.ascontiguousarray(st.x), np.ascontiguousarray(st.P), w, rows, cols, x_opt, P_opt)
        out["combined"] = FilterEstimate("combined", self.t, names, x_opt, P_opt)
        out["best"] = out[self.names[best_index(w, self.active)]]
        return out

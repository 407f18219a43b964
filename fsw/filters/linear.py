"""A bank of linear Kalman filters x_{k+1} = F x_k + w_k, z_k = H x_k + v_k, stacked and vectorised.

This is the bank of Chaer et al. 1997 §V (the 2-state tracking example, filters differing by α = [q1 q2 r1
r2], eq. 26) and the reference bank of the benchmark. Every filter keeps its own F, Q, H, R; all
of them live in stacked arrays, and one compiled call (:mod:`fsw.kernels.linear_step`) does the
predict and the Joseph-form update of every filter. Like the EKF bank it emits one ``BankRecord`` per measurement,
with the residual, innovation covariance and chi-square of every filter, and it satisfies the
same :class:`fsw.filters.protocol.Bank`. It processes the ICD's ``generic-linear`` kind, whose
dimension the scenario's H fixes.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from fsw.filters.combine import best_index, normalised_weights, weighted_estimate
from fsw.filters.errors import MeasurementRejected, UnknownFilter
from fsw.filters.estimate import StateEstimate
from fsw.filters.record import BankRecord
from fsw.filters.validate import screen
from fsw.interface.kinds import GENERIC_LINEAR
from fsw.interface.messages import Measurement
from fsw.kernels import on_first_call

_KIND = GENERIC_LINEAR.name

linear_step = on_first_call(globals(), "linear_step", "fsw.kernels.linear_step")


def _noise_covariances(R: np.ndarray, name: str) -> np.ndarray:
    """``R`` (N, m, m) checked symmetric (to rounding) and positive definite, and made exactly
    symmetric. Positive definite R keeps S = H P̄ Hᵀ + R invertible whatever P̄ is; the step
    inverts it without further checks."""
    scale = np.abs(R).max(axis=(1, 2), keepdims=True)
    if np.any(np.abs(R - R.transpose(0, 2, 1)) > 1e-12 * scale):
        raise ValueError(f"{name} must be symmetric")
    R = 0.5 * (R + R.transpose(0, 2, 1))
    try:
        np.linalg.cholesky(R)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name} must be positive definite") from None
    return R


def _padded_width(n: int) -> int:
    """n rounded up to a multiple of 8 from 8 on. The zero rows and columns stay zero through a
    step and add only zero terms to its sums; in return the step's loops run whole vectors (for
    n = 15, the loops' 15 elements all went to the scalar remainder of 16-element vector loops)
    and BLAS gets its preferred sizes."""
    return n if n < 8 else -(-n // 8) * 8


def _read_only(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


def _stack(a: ArrayLike, N: int, shape: tuple[int, ...], name: str) -> np.ndarray:
    arr = np.array(a, dtype=float)
    if arr.shape == shape:
        arr = np.broadcast_to(arr, (N, *shape)).copy()
    if arr.shape != (N, *shape):
        raise ValueError(f"{name} must have shape {shape} or {(N, *shape)}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} has non-finite entries")
    return arr


class LinearFilterBank:
    """N linear Kalman filters advanced together.

    Parameters
    ----------
    names : filter names (bank order).
    F, Q : (n, n) shared or (N, n, n) per filter — transition and process noise per step.
    H, R : (m, n) / (m, m) shared or (N, m, n) / (N, m, m) per filter.
    x0, P0 : (n,) / (n, n) shared or per filter.
    processes : per filter, the measurement kinds it updates with (default: all kinds).
    gate_chi2 : per filter, residual editing threshold on z̄ᵀS⁻¹z̄ (None: no editing).
    """

    KINDS: tuple[str, ...] = (_KIND,)

    def __init__(
        self,
        names: Sequence[str],
        F: ArrayLike,
        Q: ArrayLike,
        H: ArrayLike,
        R: ArrayLike,
        x0: ArrayLike,
        P0: ArrayLike,
        processes: Sequence[Iterable[str]] | None = None,
        gate_chi2: Sequence[float | None] | None = None,
    ):
        self.names = tuple(names)
        if len(set(self.names)) != len(self.names) or not self.names:
            raise ValueError("filter names must be unique and non-empty")
        N = len(self.names)
        n = np.shape(np.asarray(x0))[-1]
        m = np.shape(np.asarray(H))[-2]
        # The step runs on states padded with zeros to a width its loops vectorise over
        # (_padded_width); F, Q, H, x and P are read-only views of the first n rows and columns,
        # made on access (a view kept in an attribute would come back from a pickle as a copy).
        w = _padded_width(n)
        self._n = n
        self._Fw, self._Qw, self._Pw = (np.zeros((N, w, w)) for _ in range(3))
        self._Hw, self._xw = np.zeros((N, m, w)), np.zeros((N, w))
        self._Fw[:, :n, :n] = _stack(F, N, (n, n), "F")
        self._Qw[:, :n, :n] = _stack(Q, N, (n, n), "Q")
        self._Hw[:, :, :n] = _stack(H, N, (m, n), "H")
        self._R = _noise_covariances(_stack(R, N, (m, m), "R"), "R")
        self._FTw = np.ascontiguousarray(self._Fw.transpose(0, 2, 1))
        self._xw[:, :n] = _stack(x0, N, (n,), "x0")
        self._Pw[:, :n, :n] = _stack(P0, N, (n, n), "P0")
        kinds = [frozenset(self.KINDS)] * N if processes is None else [frozenset(p) for p in processes]
        if len(kinds) != N:
            raise ValueError("processes needs one entry per filter")
        self.processes = tuple(kinds)
        self._masks: dict[str, np.ndarray] = {}
        gates = list(gate_chi2) if gate_chi2 is not None else [None] * N
        if len(gates) != N:
            raise ValueError("gate_chi2 needs one entry per filter")
        self._gate = np.array([np.inf if g is None else float(g) for g in gates])
        self.active = np.ones(N, dtype=bool)
        self._all_active = True
        self._all_true = np.ones(N, dtype=bool)
        self._all_true.flags.writeable = False  # shared by every record: nobody may mutate it
        self.rejected: Counter[str] = Counter()
        self.t = 0.0
        self._updates = 0
        self._z_shape = (m,)

    @property
    def processed_count(self) -> int:
        """Measurement updates done (every one, whether it came through :meth:`process` or not)."""
        return self._updates

    @property
    def x(self) -> np.ndarray:
        """States, (N, n): a read-only view of the bank's own (copy before keeping it)."""
        return _read_only(self._xw[:, : self._n])

    @property
    def P(self) -> np.ndarray:
        """Covariances, (N, n, n): a read-only view of the bank's own (copy before keeping it)."""
        return _read_only(self._Pw[:, : self._n, : self._n])

    @property
    def F(self) -> np.ndarray:
        """Transition matrices, (N, n, n) (read-only: the step also keeps their transposes)."""
        return _read_only(self._Fw[:, : self._n, : self._n])

    @property
    def Q(self) -> np.ndarray:
        """Process noise covariances, (N, n, n) (read-only: :meth:`set_process_noise` changes them)."""
        return _read_only(self._Qw[:, : self._n, : self._n])

    @property
    def H(self) -> np.ndarray:
        """Measurement matrices, (N, m, n) (read-only)."""
        return _read_only(self._Hw[:, :, : self._n])

    @property
    def R(self) -> np.ndarray:
        """Measurement noise covariances, (N, m, m) (read-only: :meth:`set_measurement_noise`
        changes them, checked)."""
        return _read_only(self._R)

    # -- configuration at run time ---------------------------------------------------------
    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise UnknownFilter(name) from None

    def set_enabled(self, name: str, enabled: bool) -> None:
        self.active[self.index(name)] = enabled
        self._all_active = bool(self.active.all())

    def set_process_noise(self, name: str, Q: ArrayLike) -> None:
        n = self._n
        self._Qw[self.index(name), :n, :n] = _stack(Q, 1, (n, n), "Q")[0]

    def set_measurement_noise(self, name: str, R: ArrayLike) -> None:
        self._R[self.index(name)] = _noise_covariances(_stack(R, 1, self._R.shape[1:], "R"), "R")[0]

    def reinitialise(self, x: ArrayLike, P: ArrayLike) -> None:
        """Restart every filter from state ``x`` and covariance ``P`` (shared or per filter): what
        follows a parameter adaptation in Chaer et al. 1997 §V.D (steps 2 and 3)."""
        N, n = len(self.names), self._n
        self._Pw[:, :n, :n] = _stack(P, N, (n, n), "P")
        self._xw[:, :n] = _stack(x, N, (n,), "x")

    def _processes_mask(self, kind: str) -> np.ndarray:
        mask = self._masks.get(kind)
        if mask is None:
            mask = self._masks[kind] = np.array([kind in p for p in self.processes])
        return mask

    # -- filtering -------------------------------------------------------------------------
    def _check(self, values: ArrayLike) -> np.ndarray:
        z = np.asarray(values, dtype=float)
        if z.shape != self._z_shape:
            m = self._z_shape[0]
            self.rejected["bad_dimension"] += 1
            raise MeasurementRejected("bad_dimension", f"expected {m} components, got shape {z.shape}")
        if not all(map(math.isfinite, z.tolist())):
            self.rejected["non_finite"] += 1
            raise MeasurementRejected("non_finite", f"measurement {z.tolist()} is not finite")
        return z

    def update(self, z: ArrayLike, *, t: float = 0.0, seq: int = 0, kind: str = _KIND) -> BankRecord:
        """Measurement update with z (m,) for the filters that process ``kind``."""
        return self._advance(self._check(z), t, seq, kind, predict=False)

    def step(self, z: ArrayLike, *, t: float = 0.0, seq: int = 0, kind: str = _KIND) -> BankRecord:
        """One predict then one update (one measurement per transition step)."""
        return self._advance(self._check(z), t, seq, kind, predict=True)

    def _advance(self, z: np.ndarray, t: float, seq: int, kind: str, predict: bool) -> BankRecord:
        """Chaer et al. 1997 eqs. 2–6 for every enabled filter (:func:`fsw.kernels.linear_step.linear_step`):
        the filters that process ``kind`` and pass their gate update, the others keep their
        prediction; every enabled filter reports its residual, S and chi-square."""
        N, m = len(self.names), z.size
        residual = np.empty((N, m))
        S = np.empty((N, m, m))
        chi2 = np.empty(N)
        processed = np.empty(N, dtype=bool)
        if not (z.dtype == np.float64 and z.flags.c_contiguous):
            z = np.ascontiguousarray(z, dtype=float)
        linear_step(self._Fw, self._FTw, self._Qw, self._Hw, self._R, self._xw, self._Pw, z, self.active,
                    self._processes_mask(kind), self._gate, predict, residual, S, chi2, processed)
        self._updates += 1
        self.t = float(t)
        active = self._all_true if self._all_active else self.active.copy()
        return BankRecord(self.t, int(seq), kind, self.names, residual, S, chi2, processed, active)

    def process(self, meas: Measurement) -> BankRecord:
        """Predict one step and update with an ICD ``Measurement`` of kind ``generic-linear``."""
        try:
            value, _ = screen(meas, {kind: self._z_shape[0] for kind in self.KINDS})
        except MeasurementRejected as exc:
            self.rejected[exc.reason] += 1
            raise
        return self.step(value, t=float(meas.t_s), seq=int(meas.seq), kind=meas.kind)

    def propagate_to(self, t: float) -> None:
        """Move the bank's epoch to t. The filters are discrete-time: their state changes only
        at a transition step (:meth:`step`, :meth:`process`) and holds in between."""
        t = float(t)
        if not math.isfinite(t) or t < self.t:
            raise ValueError(f"cannot propagate from {self.t} back to {t}")
        self.t = t

    # -- outputs ---------------------------------------------------------------------------
    def estimates(self, weights: ArrayLike | None = None) -> dict[str, StateEstimate]:
        """Per filter (x, P), plus 'combined' (weighted sum, Chaer et al. 1997 eq. 3) and 'best'
        (highest weight) when ``weights`` are given; states named x[0], x[1], ..."""
        names = tuple(f"x[{k}]" for k in range(self._n))
        out = {name: StateEstimate(name, self.t, names, self.x[i].copy(), self.P[i].copy())
               for i, name in enumerate(self.names)}
        if weights is not None:
            w = normalised_weights(np.asarray(weights, dtype=float), self.active)
            x_opt, P_opt = weighted_estimate(self.x, self.P, w)
            out["combined"] = StateEstimate("combined", self.t, names, x_opt, P_opt)
            out["best"] = out[self.names[best_index(w, self.active)]]
        return out

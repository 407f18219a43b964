"""A bank of linear Kalman filters x_{k+1} = F x_k + w_k, z_k = H x_k + v_k, stacked and vectorised.

This is the bank of Chaer et al. 1997 §V (the 2-state tracking example, filters differing by α = [q1 q2 r1
r2], eq. 26) and the reference bank of the benchmark. Every filter keeps its own F, Q, H, R; all
of them live in stacked arrays so predict and update are a handful of batched matrix products,
whatever the number of filters. Like the EKF bank it emits one ``BankRecord`` per measurement,
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

from fsw.filters import kalman
from fsw.filters.combine import best_index, normalised_weights, weighted_estimate
from fsw.filters.errors import MeasurementRejected, UnknownFilter
from fsw.filters.estimate import StateEstimate
from fsw.filters.record import BankRecord
from fsw.filters.validate import screen
from fsw.interface.kinds import GENERIC_LINEAR
from fsw.interface.messages import Measurement

_KIND = GENERIC_LINEAR.name


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
        self.F = _stack(F, N, (n, n), "F")
        self.Q = _stack(Q, N, (n, n), "Q")
        self.H = _stack(H, N, (m, n), "H")
        self.R = _stack(R, N, (m, m), "R")
        # [P | −x] per filter: the (negated) state rides along as an extra column of the
        # covariance products (see kalman.update_explicit), which saves separate matrix-vector products.
        self._PX = np.empty((N, n, n + 1))
        self._PX[:, :, :n] = _stack(P0, N, (n, n), "P0")
        self._PX[:, :, n] = -_stack(x0, N, (n,), "x0")
        kinds = [frozenset(self.KINDS)] * N if processes is None else [frozenset(p) for p in processes]
        if len(kinds) != N:
            raise ValueError("processes needs one entry per filter")
        self.processes = tuple(kinds)
        self._masks: dict[str, np.ndarray] = {}
        self._every_filter_processes = frozenset.intersection(*self.processes)
        gates = list(gate_chi2) if gate_chi2 is not None else [None] * N
        if len(gates) != N:
            raise ValueError("gate_chi2 needs one entry per filter")
        self._gate = np.array([np.inf if g is None else float(g) for g in gates])
        self._no_gate = bool(np.all(np.isinf(self._gate)))
        self.active = np.ones(N, dtype=bool)
        self._all_active = True
        self._all_true = np.ones(N, dtype=bool)
        self._all_true.flags.writeable = False  # shared by every record: nobody may mutate it
        self.rejected: Counter[str] = Counter()
        self.t = 0.0
        self._updates = 0
        self._z_shape = (m,)
        self._n = n
        # workspace of the all-filters step: A[P | −x]
        self._work = np.empty((N, n + m, n + 1))
        self._rebuild()

    @property
    def processed_count(self) -> int:
        """Measurement updates done (every one, whether it came through :meth:`process` or not)."""
        return self._updates

    @property
    def x(self) -> np.ndarray:
        """States, (N, n)."""
        return -self._PX[:, :, -1]

    @property
    def P(self) -> np.ndarray:
        """Covariances, (N, n, n) (a view into the bank's workspace: copy before keeping it)."""
        return self._PX[:, :, :-1]

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
        self.Q[self.index(name)] = _stack(Q, 1, self.Q.shape[1:], "Q")[0]
        self._rebuild()

    def set_measurement_noise(self, name: str, R: ArrayLike) -> None:
        self.R[self.index(name)] = _stack(R, 1, self.R.shape[1:], "R")[0]
        self._rebuild()

    def reinitialise(self, x: ArrayLike, P: ArrayLike) -> None:
        """Restart every filter from state ``x`` and covariance ``P`` (shared or per filter): what
        follows a parameter adaptation in Chaer et al. 1997 §V.D (steps 2 and 3)."""
        N, n = len(self.names), self._n
        self._PX[:, :, :n] = _stack(P, N, (n, n), "P")
        self._PX[:, :, n] = -_stack(x, N, (n,), "x")

    def _all_process(self, kind: str) -> bool:
        return kind in self._every_filter_processes

    def _processes_mask(self, kind: str) -> np.ndarray:
        mask = self._masks.get(kind)
        if mask is None:
            mask = self._masks[kind] = np.array([kind in p for p in self.processes])
        return mask

    # -- filtering -------------------------------------------------------------------------
    def _rebuild(self) -> None:
        """Precompute the products of one predict-plus-update.

        With A = [F; HF], the joint prior of the predicted state and measurement is
        A P Aᵀ + [[Q, QHᵀ], [HQ, HQHᵀ + R]]. Taking [P | −x] as operand and
        Ã = [[Fᵀ, 0, (HF)ᵀ], [0, 1, 0]], A [P | −x] Ã + C gives the augmented joint prior
        [[P̄, −x̄, P̄Hᵀ], [HP̄, −ŷ, S]] of :func:`kalman.update` in two batched products (the
        measurement is written into C's otherwise zero state column, so adding C also turns −ŷ
        into z̄). B = [I; H], B̃, D play the same roles for an update without predict.
        """
        N, n, _ = self.F.shape
        m = self.H.shape[1]
        HF = self.H @ self.F
        QHt = self.Q @ self.H.transpose(0, 2, 1)
        eye = np.broadcast_to(np.eye(n), (N, n, n))
        self._A = np.concatenate([self.F, HF], axis=1)
        self._B = np.concatenate([eye, self.H], axis=1)
        self._At = self._augment(self.F, HF)
        self._Bt = self._augment(eye, self.H)
        self._C = np.zeros((N, n + m, n + 1 + m))
        self._C[:, :n, :n] = self.Q
        self._C[:, :n, n + 1 :] = QHt
        self._C[:, n:, :n] = QHt.transpose(0, 2, 1)
        self._C[:, n:, n + 1 :] = self.H @ QHt + self.R
        self._D = np.zeros((N, n + m, n + 1 + m))
        self._D[:, n:, n + 1 :] = self.R
        self._joseph = kalman.joseph_operands(self.H, self.R)

    @staticmethod
    def _augment(F: np.ndarray, HF: np.ndarray) -> np.ndarray:
        N, n, _ = F.shape
        m = HF.shape[1]
        out = np.zeros((N, n + 1, n + 1 + m))
        out[:, :n, :n] = F.transpose(0, 2, 1)
        out[:, :n, n + 1 :] = HF.transpose(0, 2, 1)
        out[:, n, n] = 1.0
        return out

    def predict(self) -> None:
        """x̄ = F x, P̄ = F P Fᵀ + Q for every enabled filter."""
        a = self.active
        F = self.F[a]
        n = F.shape[-1]
        PX = F @ self._PX[a]
        PX[:, :, :n] = PX[:, :, :n] @ F.transpose(0, 2, 1) + self.Q[a]
        self._PX[a] = PX

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
        zc = self._check(z)
        if self._all_active and self._no_gate and kind in self._every_filter_processes:
            return self._step_all(zc, t, seq, kind, self._A, self._At, self._C)
        return self._advance(zc, t, seq, kind, predict=True)

    def _step_all(self, z: np.ndarray, t: float, seq: int, kind: str, A: np.ndarray, At: np.ndarray,
                  C: np.ndarray) -> BankRecord:
        """The common case, kept free of bookkeeping: every filter active and updating."""
        n = self._n
        Mt = np.matmul(np.matmul(A, self._PX, out=self._work), At)
        C[:, n:, n] = z  # C's state column is otherwise zero: [−x̄; −ŷ] + [0; z] = [−x̄; z̄]
        Mt += C
        self._PX, residual, S, chi2, _ = kalman.update_explicit(Mt, n, self._joseph, z)
        self._updates += 1
        self.t = t = float(t)
        return BankRecord(t, int(seq), kind, self.names, residual, S, chi2, self._all_true, self._all_true)

    def _advance(self, z: np.ndarray, t: float, seq: int, kind: str, predict: bool) -> BankRecord:
        n = self._n
        if self._all_active and self._no_gate and kind in self._every_filter_processes:
            A, At, C = (self._A, self._At, self._C) if predict else (self._B, self._Bt, self._D)
            return self._step_all(z, t, seq, kind, A, At, C)
        a = self.active
        every = self._all_active
        A, At, C = (self._A, self._At, self._C) if predict else (self._B, self._Bt, self._D)
        C[:, n:, n] = z  # C's state column is otherwise zero: [−x̄; −ŷ] + [0; z] = [−x̄; z̄]
        PX = self._PX
        if not every:
            A, At, C, PX = A[a], At[a], C[a], PX[a]
        Mt = A @ PX @ At
        Mt += C
        does = self._processes_mask(kind)
        gate = None if self._no_gate else self._gate
        if not every:
            does, gate = does[a], (None if gate is None else gate[a])
        HI, E, W = self._joseph
        operands = (HI, E, W) if every else (HI[a], E, W[a])
        PX_new, residual, S, chi2, processed = kalman.update_explicit(
            Mt, n, operands, z, None if self._all_process(kind) else does, gate)
        if processed is None:
            processed = self._all_true if every else np.ones(int(a.sum()), dtype=bool)
        self._updates += 1
        self.t = float(t)
        if every:
            self._PX = PX_new
            return BankRecord(t=self.t, seq=int(seq), kind=kind, filters=self.names, residual=residual, S=S,
                              chi2=chi2, processed=processed, active=self._all_true)
        N, m = len(self.names), z.size
        self._PX[a] = PX_new
        full_res = np.full((N, m), np.nan)
        full_S = np.full((N, m, m), np.nan)
        full_chi2 = np.full(N, np.nan)
        full_processed = np.zeros(N, dtype=bool)
        full_res[a], full_S[a], full_chi2[a], full_processed[a] = residual, S, chi2, processed
        return BankRecord(t=self.t, seq=int(seq), kind=kind, filters=self.names, residual=full_res, S=full_S,
                          chi2=full_chi2, processed=full_processed, active=a.copy())

    def process(self, meas: Measurement) -> BankRecord:
        """Predict one step and update with an ICD ``Measurement`` of kind ``generic-linear``."""
        try:
            value, _ = screen(meas, {kind: self.H.shape[1] for kind in self.KINDS})
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

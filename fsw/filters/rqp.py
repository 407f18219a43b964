"""Parameter adaptation of the best filter by recursive quadratic programming (Chaer et al. 1997 §IV).

Periodically the filter the gating network prefers is re-tuned: its parameter vector α (the Q and R
pieces) is moved to the maximum of the likelihood of the last P measurements, re-processed from that
filter's state before them (eq. 21), i.e. to the minimum of

    J(α) = ½ Σᵢ [ rᵢᵀ Wᵢ⁻¹ rᵢ + ln((2π)^m |Wᵢ|) ]                                   (eq. 22)

inside the boxes of eq. 23 (C_l ≤ α ≤ C_u). The solver is scipy's SLSQP (a sequential quadratic
programming method of the family the paper's RQP belongs to); derivatives are central differences as
in the paper, but all 2·dim(α) perturbed filters run as one stacked batch, so a gradient costs about
one vectorised pass over the window instead of 2·dim(α) passes. The paper writes ln 2π|W|; the full
m-variate normaliser only adds a constant to J and does not move the optimum.

The search is split so it never holds the processor for long: :class:`RqpSearch` pauses SLSQP between
any two evaluations of J (its reverse-communication core) and resumes it exactly where it stopped, so a
caller spends a bounded slice per executive frame in the lowest-priority slot and applies the result
when it is done. Every object here holds only arrays and numbers (checkpoints pickle it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from fsw.filters.linear import LinearFilterBank as LinearFilterBankLike

#: Relative step of the central differences.
FD_STEP = 1e-4


def slsqp_core() -> Any:
    """scipy's reverse-communication core of SLSQP (``scipy.optimize._slsqplib.slsqp``).

    Imported on demand: every FSW process imports this module, and scipy.optimize costs 0.3 s of
    its start. The FSW core asks for it when the adaptation is configured or telecommanded on
    (:class:`fsw.core.adaptation.OnboardRqp`), not inside the frame of the first search slice."""
    from scipy.optimize._slsqplib import slsqp

    return slsqp


@dataclass(frozen=True)
class RqpBounds:
    """The constraint boxes of Chaer et al. 1997 eq. 23 on α: ``lower ≤ α ≤ upper`` element-wise.

    The lower bounds must be positive (eq. 23 allows Q = 0; a small positive floor stands for it,
    because the search runs on ln α)."""

    lower: tuple[float, ...]
    upper: tuple[float, ...]

    def __post_init__(self) -> None:
        lo, hi = np.asarray(self.lower, dtype=float), np.asarray(self.upper, dtype=float)
        if lo.shape != hi.shape or lo.ndim != 1 or lo.size == 0:
            raise ValueError("RQP bounds: lower and upper need the same non-zero length")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo > 0.0) and np.all(lo < hi)):
            raise ValueError(f"RQP bounds: need finite 0 < lower < upper, got {self.lower} / {self.upper}")

    def clip(self, alpha: ArrayLike) -> np.ndarray:
        return np.clip(np.asarray(alpha, dtype=float), self.lower, self.upper)


class LinearWindow:
    """The likelihood (eq. 22) of a window of measurements for a linear filter x' = F x + w,
    z = H x + v, re-processed from the state (x0, P0) before the first of them, with
    α = [diag Q, diag R] (Chaer et al. 1997 eq. 26 for the 2-state tracking example).

    ``predict_first``: whether the first measurement follows a transition step (False when the
    window starts at the a-priori epoch, as measurement 1 of the paper's example does)."""

    def __init__(self, F: ArrayLike, H: ArrayLike, x0: ArrayLike, P0: ArrayLike, Z: ArrayLike,
                 predict_first: bool = True):
        self.F = np.array(F, dtype=float)
        self.H = np.array(H, dtype=float)
        self.x0 = np.array(x0, dtype=float)
        self.P0 = np.array(P0, dtype=float)
        self.Z = np.array(Z, dtype=float)
        self.predict_first = bool(predict_first)
        n, m = self.F.shape[0], self.H.shape[0]
        if self.Z.ndim != 2 or self.Z.shape[1] != m or self.x0.shape != (n,) or self.P0.shape != (n, n):
            raise ValueError("LinearWindow: inconsistent shapes")
        self.n, self.m = n, m

    @property
    def dim(self) -> int:
        return self.n + self.m

    @property
    def size(self) -> int:
        return int(self.Z.shape[0])

    def nll(self, alphas: ArrayLike) -> np.ndarray:
        """J(α) of eq. 22 for each row of ``alphas`` (B, n + m), all rows filtered as one stack."""
        A = np.atleast_2d(np.asarray(alphas, dtype=float))
        B, n, m = A.shape[0], self.n, self.m
        Q = np.zeros((B, n, n))
        R = np.zeros((B, m, m))
        Q[:, range(n), range(n)] = A[:, :n]
        R[:, range(m), range(m)] = A[:, n:]
        x = np.broadcast_to(self.x0, (B, n)).copy()
        P = np.broadcast_to(self.P0, (B, n, n)).copy()
        F, H, Ft, Ht = self.F, self.H, self.F.T, self.H.T
        eye = np.eye(n)
        J = np.zeros(B)
        const = m * math.log(2.0 * math.pi)
        for k, z in enumerate(self.Z):
            if k > 0 or self.predict_first:
                x = x @ Ft
                P = F @ P @ Ft + Q
            r = z - x @ Ht
            W = H @ P @ Ht + R
            Winv = np.linalg.inv(W)
            _, logdet = np.linalg.slogdet(W)
            J += 0.5 * (np.einsum("bi,bij,bj->b", r, Winv, r) + logdet + const)
            K = P @ Ht @ Winv
            x = x + np.einsum("bij,bj->bi", K, r)
            IKH = eye - K @ H
            P = IKH @ P @ IKH.transpose(0, 2, 1) + K @ R @ K.transpose(0, 2, 1)  # Joseph form
        return J


def central_points(alpha: np.ndarray, bounds: RqpBounds) -> tuple[np.ndarray, np.ndarray]:
    """The 2·dim(α) points of a central difference at α (the +h rows, then the −h rows; a −h step
    below the box floor is moved up, keeping the width 2h) and the steps h."""
    d = alpha.size
    h = FD_STEP * np.asarray(alpha, dtype=float)  # relative steps: α spans decades
    pts = np.repeat(alpha[None, :], 2 * d, axis=0)
    minus = np.maximum(alpha - h, np.asarray(bounds.lower, dtype=float) * (1.0 - FD_STEP))
    pts[range(d, 2 * d), range(d)] = minus
    pts[range(d), range(d)] = minus + 2 * h
    return pts, h


def central_gradient(model: LikelihoodModel, alpha: np.ndarray, bounds: RqpBounds) -> np.ndarray:
    """∂J/∂α by central differences, the 2·dim(α) perturbed filters in one stacked pass."""
    pts, h = central_points(alpha, bounds)
    J = model.nll(pts)
    d = alpha.size
    return (J[:d] - J[d:]) / (2 * h)


class LikelihoodModel(Protocol):
    """What a search needs of a filter: J (eq. 22) of its window for a stack of α rows."""

    @property
    def dim(self) -> int: ...

    @property
    def size(self) -> int: ...

    def nll(self, alphas: ArrayLike) -> np.ndarray: ...


class RqpSearch:
    """One constrained maximum-likelihood search, resumable between any two evaluations.

    It drives scipy's SLSQP through its reverse-communication core (``scipy.optimize._slsqplib``,
    the routine ``minimize(method="SLSQP")`` itself loops over): the solver returns whenever it
    needs J or its gradient, and its whole state — a dict of numbers and a few arrays — waits here
    until the next slice. So a search can be spread over any number of frames without losing its
    quasi-Newton curvature, and the result is the one an uninterrupted ``minimize`` would give. The
    variables are u = ln α: Q and R pieces span decades and J is far better conditioned in their
    logarithms; J is divided by the window length so the tolerance means the same for any P.

    ``nll_before`` is J at the starting α (clipped into the box); ``best`` / ``nll_best`` the lowest
    J evaluated so far; ``done`` once SLSQP stops (``status``: its exit mode, 0 = converged) or the
    iteration cap is spent."""

    def __init__(self, model: LikelihoodModel, bounds: RqpBounds, alpha0: ArrayLike, *, max_iter: int = 100,
                 ftol: float = 1e-6):
        self.model = model
        self.bounds = bounds
        a0 = bounds.clip(alpha0)
        if a0.size != len(bounds.lower) or a0.size != model.dim:
            raise ValueError("RqpSearch: α, bounds and model disagree on the dimension")
        n = a0.size
        self._scale = 1.0 / max(1, model.size)
        self._xl = np.log(np.asarray(bounds.lower, dtype=float))
        self._xu = np.log(np.asarray(bounds.upper, dtype=float))
        self._x = np.log(a0)
        # the solver's state and workspace, sized as scipy's own driver sizes them (no constraints)
        self._state: dict[str, float | int] = {
            "acc": float(ftol), "alpha": 0.0, "f0": 0.0, "gs": 0.0, "h1": 0.0, "h2": 0.0, "h3": 0.0,
            "h4": 0.0, "t": 0.0, "t0": 0.0, "tol": 10.0 * float(ftol), "exact": 0, "inconsistent": 0,
            "reset": 0, "iter": 0, "itermax": int(max_iter), "line": 0, "m": 0, "meq": 0, "mode": 0, "n": n,
        }
        self._indices = np.zeros(max(2 * n + 2, 1), dtype=np.int32)
        self._buffer = np.zeros(n * (n + 1) // 2 + 8 * n * n + 35 * n + 28 + 2 * n * (n + 1))
        self._mult = np.zeros(2 * n + 2)
        self._C = np.zeros((1, n), order="F")
        self._d = np.zeros(1)
        self._g = np.zeros(n)
        self._fx = 0.0
        self._need = "fg"  # mode 0 on entry: the solver wants J and its gradient at the start
        self.evaluations = 0  # α rows evaluated (a gradient costs 2·dim(α))
        self.done = False
        self.status = -1
        self.best = a0.copy()
        self.nll_before = self.nll_best = float("inf")
        self.start = a0.copy()

    @property
    def iterations(self) -> int:
        return int(self._state["iter"])

    @property
    def message(self) -> str:
        return _EXIT.get(self.status, "running")

    def _alpha(self) -> np.ndarray:
        # SLSQP may step past a bound by an ulp or two: never evaluate outside the box
        return self.bounds.clip(np.exp(np.clip(self._x, self._xl, self._xu)))

    def request(self) -> np.ndarray | None:
        """The α rows whose J the solver needs next — one row for J, 2·dim(α) for the central
        differences of its gradient (see :func:`central_points`) — or None once the search is done.
        Answer with :meth:`provide`; a caller may take as long as it likes in between."""
        slsqp = slsqp_core()  # a module attribute, not state: a checkpoint pickles the search
        while not self._need and not self.done:
            slsqp(self._state, self._fx, self._g, self._C, self._d, self._x, self._mult, self._xl, self._xu,
                   self._buffer, self._indices)
            mode = int(self._state["mode"])
            if mode == 1:
                self._need = "f"
            elif mode == -1:
                self._need = "g"
            else:
                self.done, self.status = True, mode
        if self.done:
            return None
        a = self._alpha()
        return a[None, :] if "f" in self._need else central_points(a, self.bounds)[0]

    def provide(self, J: ArrayLike) -> None:
        """J of the rows :meth:`request` returned (non-finite values are rejected steps)."""
        J = np.asarray(J, dtype=float)
        a = self._alpha()
        self.evaluations += J.size
        if "f" in self._need:
            j = float(J[0]) if math.isfinite(float(J[0])) else 1e300
            if self.nll_before == float("inf"):
                self.nll_before = j
            if j < self.nll_best:
                self.best, self.nll_best = a, j
            self._fx = self._scale * j
            self._need = self._need.replace("f", "")
            return
        h = central_points(a, self.bounds)[1]
        d = a.size
        g = (J[:d] - J[d:]) / (2 * h) * a  # chain rule for u = ln α
        self._g = np.where(np.isfinite(g), self._scale * g, 0.0)
        self._need = ""

    def step(self, evaluations: int) -> bool:
        """Advance by at most ``evaluations`` α rows (at least one request); True when done."""
        spent = 0
        while True:
            rows = self.request()
            if rows is None:
                return True
            if spent and spent + len(rows) > evaluations:
                return False
            self.provide(self.model.nll(rows))
            spent += len(rows)

    def run(self, slice_evaluations: int = 50) -> np.ndarray:
        """Run to the end (bounded by the iteration cap); returns the best α."""
        while not self.step(slice_evaluations):
            pass
        return self.best


_EXIT = {0: "converged", 1: "running", -1: "running", 2: "more equality constraints than variables",
         3: "more than 3*n iterations in LSQ subproblem", 4: "inequality constraints incompatible",
         5: "singular matrix E in LSQ subproblem", 6: "singular matrix C in LSQ subproblem",
         7: "rank-deficient equality constraint subproblem", 8: "positive directional derivative for linesearch",
         9: "iteration limit reached"}


@dataclass(frozen=True)
class RqpOutcome:
    """One finished adaptation: which filter, α and J (eq. 22) before and after, and its cost."""

    t: float
    filter: str
    alpha_before: tuple[float, ...]
    alpha_after: tuple[float, ...]
    nll_before: float
    nll_after: float
    iterations: int
    evaluations: int
    applied: bool


class LinearBankAdaptation:
    """Periodic RQP adaptation of the best filter of a :class:`~fsw.filters.linear.LinearFilterBank`
    (Chaer et al. 1997 §IV–§V.D).

    Call :meth:`before` before the bank takes a measurement and :meth:`after` once it has (with the
    gating weights after it). Every ``every`` measurements the filter of largest weight is re-tuned
    on the window just closed, from its state before the window (kept in a snapshot: the window's
    measurements sit in a bounded buffer). The search evaluates at most ``slice_evaluations`` α rows per
    measurement, so it spans measurements and never delays one; when it ends, the new α goes to that
    filter and, as in §V.D, every filter restarts from that filter's estimate with covariance
    ``P_restart`` (None: states are kept). A result within ``min_change`` (relative, every
    component) of the current α is not applied ("the update would not be necessary")."""

    def __init__(self, bank: "LinearFilterBankLike", bounds: RqpBounds, every: int, *,
                 slice_evaluations: int = 20, max_iter: int = 100, min_change: float = 0.05,
                 P_restart: ArrayLike | None = None):
        if every < 2:
            raise ValueError("RQP window must hold at least 2 measurements")
        self.bank = bank
        self.bounds = bounds
        self.every = int(every)
        self.slice_evaluations = int(slice_evaluations)
        self.max_iter = int(max_iter)
        self.min_change = float(min_change)
        self.P_restart = None if P_restart is None else np.array(P_restart, dtype=float)
        self.window: list[np.ndarray] = []
        self._snapshot: tuple[np.ndarray, np.ndarray, bool] | None = None
        self.search: RqpSearch | None = None
        self._target = 0
        self.outcomes: list[RqpOutcome] = []

    def alpha(self, i: int) -> np.ndarray:
        """Filter i's α = [diag Q, diag R] (eq. 26)."""
        return np.concatenate([np.diag(self.bank.Q[i]), np.diag(self.bank.R[i])])

    def before(self) -> None:
        if not self.window:
            self._snapshot = (self.bank.x.copy(), self.bank.P.copy(), self.bank.processed_count > 0)

    def after(self, z: ArrayLike, weights: ArrayLike, t: float) -> RqpOutcome | None:
        self.window.append(np.array(z, dtype=float))
        outcome = None
        if self.search is not None and self.search.step(self.slice_evaluations):
            outcome = self._apply(t)
        if len(self.window) >= self.every:
            if self.search is None and self._snapshot is not None:
                i = int(np.argmax(np.where(self.bank.active, np.asarray(weights, dtype=float), -np.inf)))
                x0, P0, predict_first = self._snapshot
                model = LinearWindow(self.bank.F[i], self.bank.H[i], x0[i], P0[i], np.array(self.window),
                                     predict_first)
                self.search = RqpSearch(model, self.bounds, self.alpha(i), max_iter=self.max_iter)
                self._target = i
            self.window = []
        return outcome

    def _apply(self, t: float) -> RqpOutcome:
        s = self.search
        assert s is not None
        self.search = None
        i = self._target
        before = self.alpha(i)
        after = s.best
        applied = bool(np.any(np.abs(after - before) > self.min_change * np.maximum(np.abs(before), 1e-12)))
        if applied:
            n = self.bank.Q.shape[1]
            name = self.bank.names[i]
            self.bank.set_process_noise(name, np.diag(after[:n]))
            self.bank.set_measurement_noise(name, np.diag(after[n:]))
            if self.P_restart is not None:
                self.bank.reinitialise(self.bank.x[i].copy(), self.P_restart)
        out = RqpOutcome(float(t), self.bank.names[i], tuple(before.tolist()), tuple(after.tolist()),
                         s.nll_before, s.nll_best, s.iterations, s.evaluations, applied)
        self.outcomes.append(out)
        return out

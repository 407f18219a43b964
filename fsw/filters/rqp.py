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

The search is split so it never holds the processor for long: :class:`RqpSearch` runs at most a
given number of SLSQP iterations per call and resumes from its best point on the next call (warm
start), so a caller can spend one slice per executive frame in the lowest-priority slot and apply the
result when it is done. Every object here holds only arrays and numbers (checkpoints pickle it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import minimize

if TYPE_CHECKING:
    from fsw.filters.linear import LinearFilterBank as LinearFilterBankLike

#: Relative step of the central differences (of the box width, so bounds are never crossed by much).
FD_STEP = 1e-4


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


def central_gradient(model: LinearWindow, alpha: np.ndarray, bounds: RqpBounds) -> np.ndarray:
    """∂J/∂α by central differences, the 2·dim(α) perturbed filters in one stacked pass."""
    d = alpha.size
    h = FD_STEP * (np.asarray(bounds.upper) - np.asarray(bounds.lower))
    pts = np.repeat(alpha[None, :], 2 * d, axis=0)
    pts[range(d), range(d)] += h
    pts[range(d, 2 * d), range(d)] -= h
    # a step outside the box could make Q or R indefinite: shift it inside, keep the width
    lo = np.asarray(bounds.lower)
    pts[range(d, 2 * d), range(d)] = np.maximum(pts[range(d, 2 * d), range(d)], lo)
    pts[range(d), range(d)] = pts[range(d, 2 * d), range(d)] + 2 * h
    J = model.nll(pts)
    return (J[:d] - J[d:]) / (2 * h)


@dataclass
class RqpSearch:
    """One constrained maximum-likelihood search, resumable in slices (see the module docstring).

    ``nll_before`` is J at the starting α (the filter's current parameters); ``best`` / ``nll_best``
    the lowest J found so far; ``done`` once SLSQP reports convergence or failure, or the total
    iteration cap is spent."""

    model: LinearWindow
    bounds: RqpBounds
    alpha0: np.ndarray
    max_iter: int = 40
    ftol: float = 1e-6
    iterations: int = 0
    evaluations: int = 0
    done: bool = False
    message: str = ""
    best: np.ndarray = field(init=False)
    nll_before: float = field(init=False)
    nll_best: float = field(init=False)

    def __post_init__(self) -> None:
        self.alpha0 = self.bounds.clip(self.alpha0)
        if self.alpha0.size != len(self.bounds.lower) or self.alpha0.size != self.model.dim:
            raise ValueError("RqpSearch: α, bounds and model disagree on the dimension")
        self.best = self.alpha0.copy()
        self.nll_before = self.nll_best = float(self.model.nll(self.alpha0)[0])
        self.evaluations = 1

    def _fun(self, a: np.ndarray) -> float:
        self.evaluations += 1
        return float(self.model.nll(a)[0])

    def _jac(self, a: np.ndarray) -> np.ndarray:
        self.evaluations += 2 * a.size
        return central_gradient(self.model, np.asarray(a, dtype=float), self.bounds)

    def step(self, iterations: int) -> bool:
        """Run at most ``iterations`` SLSQP iterations from the best point so far; True when done."""
        if self.done:
            return True
        k = max(1, min(int(iterations), self.max_iter - self.iterations))
        # SLSQP works on u = ln α: Q and R pieces span decades and J is far better conditioned in
        # their logarithms, which also lets a restarted slice (identity Hessian again) progress.
        # J is a sum over the window: scaled to O(1) so ftol means the same for any P.
        scale = 1.0 / max(1, self.model.Z.shape[0])

        def fun(u: np.ndarray) -> float:
            return scale * self._fun(np.exp(u))

        def jac(u: np.ndarray) -> np.ndarray:
            a = np.exp(u)
            return scale * self._jac(a) * a

        res = minimize(fun, np.log(self.best), jac=jac, method="SLSQP",
                       bounds=list(zip(np.log(self.bounds.lower), np.log(self.bounds.upper))),
                       options={"maxiter": k, "ftol": self.ftol})
        self.iterations += int(res.nit) if res.nit else k
        cand = self.bounds.clip(np.exp(res.x))
        if np.all(np.isfinite(cand)):
            j = float(self.model.nll(cand)[0])
            self.evaluations += 1
            if j < self.nll_best:
                self.best, self.nll_best = cand, j
        if res.status != 9 or self.iterations >= self.max_iter:  # 9: iteration limit of this slice
            self.done = True
            self.message = str(res.message)
        return self.done

    def run(self, slice_iterations: int = 5) -> np.ndarray:
        """Run to the end (bounded by ``max_iter``); returns the best α."""
        while not self.step(slice_iterations):
            pass
        return self.best


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
    measurements sit in a bounded buffer). The search runs ``slice_iterations`` SLSQP iterations per
    measurement, so it spans measurements and never delays one; when it ends, the new α goes to that
    filter and, as in §V.D, every filter restarts from that filter's estimate with covariance
    ``P_restart`` (None: states are kept). A result within ``min_change`` (relative, every
    component) of the current α is not applied ("the update would not be necessary")."""

    def __init__(self, bank: "LinearFilterBankLike", bounds: RqpBounds, every: int, *,
                 slice_iterations: int = 5, max_iter: int = 40, min_change: float = 0.05,
                 P_restart: ArrayLike | None = None):
        if every < 2:
            raise ValueError("RQP window must hold at least 2 measurements")
        self.bank = bank
        self.bounds = bounds
        self.every = int(every)
        self.slice_iterations = int(slice_iterations)
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
        if self.search is not None and self.search.step(self.slice_iterations):
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

"""Onboard RQP adaptation of the best filter (Chaer et al. 1997 §IV) under the frame executive.

Every ``rqp.every`` measurements (a window), the filter the gating network prefers is re-tuned on
the window just closed: J (eq. 22) of the window re-processed from that filter's state before it is
minimised over α (the ``rqp.params`` noise parameters, inside their eq. 23 boxes) by
:class:`fsw.filters.rqp.RqpSearch` (scipy's SLSQP, paused between evaluations), starting from the
filter's current α. Re-processing needs the bank as it was before the window: a copy of it is taken
when a window opens (one copy at a time, plus the window's measurements — bounded). J of one α row is
computed on a further copy of that snapshot in which only the tuned filter is enabled.

The work is split into slices of at most ``rqp.slice_steps`` filter steps (one measurement
re-processed for one α row), each one stage of the lowest priority class in its own lane, submitted
after a measurement's job: it never delays the bank, and its CPU is charged to the frame that runs it
(so it shows in the budget telemetry). When the search ends the new α is applied to that filter
(unless every component moved less than ``rqp.min_change``) and the outcome is reported.
Everything here is plain data: the FSW checkpoint pickles it.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass

import numpy as np

from fsw.executive.config import BudgetConfig
from fsw.filters.bank import FilterBank
from fsw.filters.errors import MeasurementRejected
from fsw.filters.rqp import RqpBounds, RqpSearch, slsqp_core
from fsw.filters.rqp_config import RqpConfig, RqpParam
from fsw.core.telemetry import stamp
from fsw.interface import messages as m
from fsw.interface.messages import Measurement


@dataclass
class _Evaluation:
    """J of a stack of α rows, computed a few filter steps at a time."""

    rows: np.ndarray
    row: int = 0
    k: int = 0
    bank: FilterBank | None = None
    J: np.ndarray | None = None


@dataclass(frozen=True)
class Adapted:
    """A finished adaptation, for telemetry."""

    t: float
    filter: str
    params: tuple[str, ...]
    alpha_before: tuple[float, ...]
    alpha_after: tuple[float, ...]
    nll_before: float
    nll_after: float
    window: int
    iterations: int
    evaluations: int
    cost: float
    applied: bool
    status: str


class OnboardRqp:
    """The adaptation's state in the FSW core: window, snapshot, search in progress."""

    # slotted: see fsw.executive.FrameExecutive
    __slots__ = ("config", "_work_units", "_cpu_scale", "enabled", "every", "window", "_snapshot", "_search",
                 "_target", "_target_window", "_base", "_eval", "_cost", "adaptations", "cost_total", "_params")

    def __init__(self, config: RqpConfig, budget: BudgetConfig):
        self.config = config
        # what a slice is charged, as the executive charges it: declared work units, or measured
        # CPU x cpu_scale (so the telemetry of a work-unit run is reproducible)
        self._work_units = budget.mode == "work-units"
        self._cpu_scale = budget.cpu_scale
        self.enabled = config.enabled
        if self.enabled:
            slsqp_core()  # the solver loaded now, not in the frame of the first search slice
        self.every = config.every
        self.window: list[Measurement] = []
        self._snapshot: FilterBank | None = None
        self._search: RqpSearch | None = None
        self._target = ""
        self._target_window: tuple[Measurement, ...] = ()
        self._base: FilterBank | None = None
        self._eval: _Evaluation | None = None
        self._cost = 0.0
        self.adaptations = 0
        self.cost_total = 0.0

        self._params: tuple[RqpParam, ...] = ()

    @property
    def params(self) -> tuple[str, ...]:
        """The components of α of the search in progress."""
        return tuple(p.name for p in self._params)

    @property
    def busy(self) -> bool:
        """A search is in progress: a slice should follow the next measurement."""
        return self._search is not None

    def set(self, enabled: bool | None = None, every: int | None = None) -> None:
        """Telecommanded change; a new window size or disabling drops the window being collected
        (a search in progress finishes)."""
        if enabled is not None and enabled != self.enabled:
            self.enabled = enabled
            self.window, self._snapshot = [], None
            if enabled:
                slsqp_core()
        if every is not None and every != self.every:
            self.every = every
            self.window, self._snapshot = [], None

    # -- collecting windows (in the bank stage) --------------------------------------------------
    def before(self, bank: FilterBank) -> None:
        if self.enabled and not self.window:
            self._snapshot = copy.deepcopy(bank)

    def after(self, bank: FilterBank, meas: Measurement, best: str) -> None:
        """The bank took ``meas``; ``best`` is the filter the gating network prefers now."""
        if not self.enabled or self._snapshot is None:
            return
        self.window.append(meas)
        if len(self.window) < self.every:
            return
        if self._search is None:
            self._start(bank, best)
        self.window, self._snapshot = [], None

    def _start(self, bank: FilterBank, best: str) -> None:
        # a measurement-noise scale of a kind the filter does not process leaves J flat: not searched
        self._params = tuple(p for p in self.config.params if not p.name.startswith("sigma_scale.")
                             or bank.processes(best, p.name.split(".", 1)[1]))
        if not self._params:
            return
        base = self._snapshot
        assert base is not None
        base.set_enabled(best, True)
        for name in base.names:  # re-processing concerns the tuned filter only
            if name != best:
                base.set_enabled(name, False)
        lo = tuple(p.lower for p in self._params)
        hi = tuple(p.upper for p in self._params)
        alpha0 = np.array([bank.get_param(best, p) for p in self.params])
        self._base, self._target, self._target_window = base, best, tuple(self.window)
        self._search = RqpSearch(_Window(len(self.params), len(self.window)), RqpBounds(lo, hi), alpha0,
                                 max_iter=self.config.max_iter, ftol=self.config.ftol)
        self._eval = None
        self._cost = 0.0

    # -- one slice (an executive stage) --------------------------------------------------------
    def slice(self, bank: FilterBank, t: float) -> Adapted | None:
        """At most ``slice_steps`` filter steps of the search; the outcome when it ends."""
        if self._search is None:
            return None
        c0 = time.thread_time()
        steps = 0
        search = self._search
        done = False
        while steps < self.config.slice_steps:
            if self._eval is None:
                rows = search.request()
                if rows is None:
                    done = True
                    break
                self._eval = _Evaluation(rows=rows, J=np.zeros(len(rows)))
            steps += self._advance(self._eval, self.config.slice_steps - steps)
            if self._eval.row >= len(self._eval.rows):
                assert self._eval.J is not None
                search.provide(self._eval.J)
                self._eval = None
        self._cost += self.config.slice_cost if self._work_units else (time.thread_time() - c0) * self._cpu_scale
        if not done and search.request() is not None:
            return None
        return self._finish(bank, t)

    def _advance(self, ev: _Evaluation, budget: int) -> int:
        """Re-process up to ``budget`` measurements of the window for the current row."""
        assert self._base is not None and ev.J is not None
        steps = 0
        i = self._base.index(self._target)
        while steps < budget and ev.row < len(ev.rows):
            if ev.bank is None:
                ev.bank = copy.deepcopy(self._base)
                try:
                    for p, v in zip(self.params, ev.rows[ev.row]):
                        ev.bank.set_param(self._target, p, float(v))
                except ValueError:
                    ev.J[ev.row] = math.inf
                    ev.row, ev.k, ev.bank = ev.row + 1, 0, None
                    continue
            meas = self._target_window[ev.k]
            try:
                rec = ev.bank.process(meas)
                if rec.processed[i]:
                    S = np.atleast_2d(rec.S[i])
                    r = np.atleast_1d(rec.residual[i])
                    _, logdet = np.linalg.slogdet(2.0 * math.pi * S)
                    ev.J[ev.row] += 0.5 * (float(r @ np.linalg.solve(S, r)) + logdet)
            except (MeasurementRejected, np.linalg.LinAlgError):
                pass  # what the bank rejected in flight it rejects here too: no information
            steps += 1
            ev.k += 1
            if ev.k >= len(self._target_window):
                ev.row, ev.k, ev.bank = ev.row + 1, 0, None
        return steps

    def _finish(self, bank: FilterBank, t: float) -> Adapted:
        search = self._search
        assert search is not None
        before = tuple(bank.get_param(self._target, p) for p in self.params)
        after = tuple(float(x) for x in search.best)
        applied = any(abs(a - b) > self.config.min_change * abs(b) for a, b in zip(after, before))
        if applied:
            for p, v in zip(self.params, after):
                bank.set_param(self._target, p, v)
        self.adaptations += 1
        self.cost_total += self._cost
        out = Adapted(t=float(t), filter=self._target, params=self.params, alpha_before=before, alpha_after=after,
                      nll_before=search.nll_before, nll_after=search.nll_best, window=len(self._target_window),
                      iterations=search.iterations, evaluations=search.evaluations, cost=self._cost, applied=applied,
                      status=search.message)
        self._search, self._base, self._eval, self._target_window = None, None, None, ()
        return out


def report_message(a: Adapted) -> m.RqpReport:
    """The ICD telemetry of a finished adaptation."""
    return m.RqpReport(t_s=a.t, timestamp=stamp(a.t), filter=a.filter, params=a.params, alpha_before=a.alpha_before,
                       alpha_after=a.alpha_after, nll_before=a.nll_before, nll_after=a.nll_after, window=a.window,
                       iterations=a.iterations, evaluations=a.evaluations, cost=a.cost, applied=a.applied,
                       status=a.status)


class _Window:
    """Dimensions of the search's model; J itself is computed slice by slice by :class:`OnboardRqp`
    (the search is driven through ``request``/``provide`` only)."""

    def __init__(self, dim: int, size: int):
        self._dim, self._size = dim, size

    @property
    def dim(self) -> int:
        return self._dim

    @property
    def size(self) -> int:
        return self._size

    def nll(self, alphas: object) -> np.ndarray:
        raise RuntimeError("J of the onboard window is computed slice by slice")

"""Filter-bank rows of ``navbank bench``: our banks against FilterPy and against themselves.

* ``linear-bank-vs-filterpy``: one measurement update (predict + update) of a linear bank of
  N = 6 filters, n = 15 states, 2-D measurements, against a bank of FilterPy ``KalmanFilter``
  objects doing the same work (predict + Joseph update each). Goal ≥ 20×. The row also gives
  the arithmetic floor of that work at numpy's batched-matmul rate (:func:`dense_floor_us`) and
  the ratio it would allow (``ratio_ceiling``).
* ``ekf-update-vs-filterpy-N3`` / ``-N6``: the onboard EKF bank's measurement update
  (:meth:`fsw.filters.ekf.EKFStack.update`: gain, Joseph covariance, chi-square of every filter)
  of the ``nominal`` (3 filters) and ``acs-q`` (6 filters) banks, n = the bank's state count,
  a 1-D (Doppler-like) measurement, against one FilterPy ``ExtendedKalmanFilter`` per filter with
  the same n and m doing its ``update`` (Joseph form) with the same Jacobian and prediction
  handed in. FilterPy has no orbit propagator, so the time update and the measurement models are
  outside both sides. Goal ≥ 10×.
* ``ekf-bank-stacking-3`` / ``-6``: the whole EKF bank on the simulator's InSight approach stream
  (propagation, models, update), µs per measurement, against the same filters run as separate
  one-filter banks: what stacking across filters saves (goal: not slower, ≥ 1×).

Timings interleave ours and the reference and keep the best of several repeats, so other load
on the machine affects both alike. FilterPy is the ``bench`` extra: without it its rows are
skipped with a one-line note.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from fsw.filters.bank import FilterBank
from fsw.filters.config import BankConfig
from fsw.filters.ekf import EKFStack
from fsw.filters.kinds import FILTER_KINDS
from fsw.filters.linear import LinearFilterBank
from fsw.models.environment import Environment
from tools.bench.core import matmul_rate
from tools.bench.rows import Goal, make_row

LINEAR_GOAL = Goal("cost", ">=", 20.0)
EKF_GOAL = Goal("cost", ">=", 10.0)
STACKING_GOAL = Goal("cost", ">=", 1.0)


def _best_of(fn: Callable[[], None], number: int, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def bench_linear(N: int = 6, n: int = 15, m: int = 2, number: int = 400, repeat: int = 15, seed: int = 0) -> dict[str, Any]:
    """µs per bank measurement update: our stacked bank vs N FilterPy KalmanFilters."""
    from filterpy.kalman import KalmanFilter

    rng = np.random.default_rng(seed)
    F = np.array([np.eye(n) + 0.01 * np.triu(rng.standard_normal((n, n)), 1) for _ in range(N)])
    Q = np.array([np.diag(rng.uniform(1e-4, 1e-2, n)) for _ in range(N)])
    H = rng.standard_normal((N, m, n))
    R = np.array([np.diag(rng.uniform(0.5, 2.0, m)) for _ in range(N)])
    x0, P0 = np.zeros(n), np.eye(n) * 10.0
    bank = LinearFilterBank([f"f{i}" for i in range(N)], F, Q, H, R, x0, P0)
    kfs = []
    for i in range(N):
        kf = KalmanFilter(dim_x=n, dim_z=m)
        kf.F, kf.Q, kf.H, kf.R = F[i], Q[i], H[i], R[i]
        kf.x, kf.P = x0.copy()[:, None], P0.copy()
        kfs.append(kf)
    zs = rng.standard_normal((number, m))
    it: Iterator[np.ndarray] = iter(())

    def ours() -> None:
        bank.step(next(it))

    def reference() -> None:
        z = next(it)
        for kf in kfs:
            kf.predict()
            kf.update(z)

    t_ours = t_ref = float("inf")
    for _ in range(repeat):  # interleaved
        it = iter(zs)
        t_ours = min(t_ours, _best_of(ours, number, 1))
        it = iter(zs)
        t_ref = min(t_ref, _best_of(reference, number, 1))
    floor = dense_floor_us(N, n)
    return make_row("linear-bank-vs-filterpy", t_ours * 1e6, t_ref * 1e6, "us/update", LINEAR_GOAL,
                    "FilterPy time / ours for the same predict + update (higher is better)",
                    filters=N, states=n, measurement_dim=m,
                    reference_impl="filterpy.kalman.KalmanFilter predict+update, one per filter",
                    dense_floor_us=floor, ratio_ceiling=t_ref * 1e6 / floor)


def dense_floor_us(N: int, n: int) -> float:
    """µs that the dense n × n products of one predict + Joseph update of N filters take at the
    rate numpy reaches on batched (N, n, n) matmuls here and now: the floor under any
    implementation that runs at that rate, whatever its overhead.

    Four products per filter: F P Fᵀ (two) and the Joseph form's (I − KH) P̄ (I − KH)ᵀ (two);
    the gain and K R Kᵀ (of inner width m) are left out, so the floor is a lower bound. The row's
    ``ratio_ceiling`` = FilterPy's time / this floor is the highest ratio such an implementation
    could reach."""
    return 4 * 2.0 * n**3 * N / matmul_rate(N, n) * 1e6


def _entry_stack(config: BankConfig, env: Environment) -> EKFStack:
    from tools.bench.synthetic import entry_state

    t, r, v = entry_state()
    return EKFStack(config, t, r, v, env)


def bench_ekf_filterpy(config: BankConfig, name: str, env: Environment, number: int = 300, repeat: int = 7,
                       seed: int = 0) -> dict[str, Any]:
    """µs per measurement update: the EKF bank's stacked update vs one FilterPy EKF per filter."""
    from filterpy.kalman import ExtendedKalmanFilter

    stack = _entry_stack(config, env)
    N, n = stack.x.shape
    m = 1
    rng = np.random.default_rng(seed)
    # a Doppler-like Jacobian: sensitive to velocity, weakly to position and the clock
    H = np.zeros((N, m, n))
    H[:, 0, 0:3] = rng.standard_normal(3) * 1e-6
    H[:, 0, 3:6] = rng.standard_normal(3)
    H[:, 0, 6:] = rng.standard_normal(n - 6) * 1e-3
    R = np.full((N, m, m), 1e-12)
    does = np.ones(N, dtype=bool)
    x0, P0 = stack.x.copy(), stack.P.copy()
    ekfs = []
    for i in range(N):
        ekf = ExtendedKalmanFilter(dim_x=n, dim_z=m)
        ekf.x, ekf.P, ekf.R = x0[i].copy()[:, None], P0[i].copy(), R[i]
        ekfs.append(ekf)
    h = np.zeros((N, m))
    zs = rng.standard_normal((number, m)) * 1e-6
    it: Iterator[np.ndarray] = iter(())

    def ours() -> None:
        stack.update(next(it), h, H, R, does, None)

    def reference() -> None:
        z = next(it)
        for i, ekf in enumerate(ekfs):
            Hi, hi = H[i], h[i][:, None]
            ekf.update(z[:, None], lambda _x: Hi, lambda _x: hi)

    def reset() -> None:
        stack.x, stack.P = x0.copy(), P0.copy()
        for i, ekf in enumerate(ekfs):
            ekf.x, ekf.P = x0[i].copy()[:, None], P0[i].copy()

    t_ours = t_ref = float("inf")
    for _ in range(repeat):  # interleaved, both from the same prior
        reset()
        it = iter(zs)
        t_ours = min(t_ours, _best_of(ours, number, 1))
        it = iter(zs)
        t_ref = min(t_ref, _best_of(reference, number, 1))
    return make_row(name, t_ours * 1e6, t_ref * 1e6, "us/update", EKF_GOAL,
                    "FilterPy time / ours for the same measurement update (higher is better)",
                    filters=N, states=n, measurement_dim=m,
                    reference_impl="filterpy.kalman.ExtendedKalmanFilter.update (Joseph form), one per filter; "
                                   "ours: EKFStack.update")


def bench_stacking(config: BankConfig, name: str, stream: tuple, env: Environment, repeat: int = 3) -> dict[str, Any]:
    """µs per measurement of the whole bank vs the same filters as separate one-filter banks."""
    t0, r0, v0, meas, label = stream

    def run(cfg: BankConfig) -> float:
        bank = FilterBank(cfg, t0, r0, v0, env=env)
        start = time.perf_counter()
        for m in meas:
            bank.process(m)
        return time.perf_counter() - start

    t_ours = t_ref = float("inf")
    for _ in range(repeat):
        t_ours = min(t_ours, run(config))
        t_ref = min(t_ref, sum(run(BankConfig(filters=(f,), maneuvers=config.maneuvers)) for f in config.filters))
    k = len(meas)
    return make_row(name, t_ours / k * 1e6, t_ref / k * 1e6, "us/measurement", STACKING_GOAL,
                    "one-filter banks' time / the stacked bank's (higher is better)",
                    filters=len(config.filters), states=len(FilterBank(config, t0, r0, v0, env=env).state_names),
                    measurements=k, kinds={kind: sum(1 for m in meas if m.kind == kind) for kind in FILTER_KINDS},
                    reference_impl="the same filters as separate one-filter banks", stream=label)


def insight_stream(count: int, env: Environment) -> tuple[float, np.ndarray, np.ndarray, tuple, str]:
    """The simulator's InSight approach stream (first ``count`` measurements of a 4-day arc), or
    the synthetic one from the onboard models without the simulator."""
    try:
        import dataclasses

        from sim.config import SimConfig
        from sim.stream import generate
    except ImportError:
        from tools.bench.synthetic import make_run

        synthetic = make_run(span_days=4.0, max_measurements=count, env=env)
        return (synthetic.t0, synthetic.position_km, synthetic.velocity_km_s, synthetic.measurements,
                "synthetic InSight-like (onboard models)")
    cfg = SimConfig()
    cfg = dataclasses.replace(cfg, trajectory=dataclasses.replace(cfg.trajectory, span_days=4.0))
    run = generate(cfg, seed=1)
    truth = run.truth_at(run.t_start)
    meas = tuple(run.measurements[:count])
    return run.t_start, np.array(truth.position_km), np.array(truth.velocity_km_s), meas, "sim InSight approach, last 4 days"


__all__ = ["bench_linear", "bench_ekf_filterpy", "bench_stacking", "dense_floor_us", "insight_stream"]

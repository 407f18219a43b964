"""``navbank bench``: cost of the filter banks, measured in this process against references.

* ``linear-bank``: one measurement update (predict + update) of a linear bank of N = 6 filters,
  n = 15 states, 2-D measurements, against a bank of FilterPy ``KalmanFilter`` objects doing the
  same work (predict + Joseph update each). Target: at least 5× faster. FilterPy is the ``bench``
  extra; without it this entry is skipped with a one-line note.
* ``ekf-bank-3`` / ``ekf-bank-6``: the onboard EKF bank (``nominal`` and ``acs-q`` presets) on the
  simulator's InSight approach stream (range, Doppler, optical; a synthetic stream from the
  onboard models if the simulator is not installed), µs per measurement, against the same
  filters run as separate one-filter banks (what the stacking across filters saves).
* ``icd-decode``: strict decoding of the stream's measurements (``codec.from_json``: every type,
  range, size and key checked) against ``json.loads`` of the same payloads, which checks nothing;
  µs per message, and ``messages_per_s`` strict.

Filter consistency (NEES/NIS against the simulator's truth over Monte Carlo seeds) is measured
by :mod:`tools.bench.consistency`.

Timings interleave ours and the reference and keep the best of several repeats, so other
load on the machine affects both alike. ``--json`` prints one JSON object per line with
``name``, ``ours``, ``reference``, ``unit``, ``ratio`` (reference ÷ ours) and details.
"""

from __future__ import annotations

import json as _json
import sys
import time
from collections.abc import Callable, Iterator
from typing import IO, Any

import numpy as np

from fsw.filters.bank import FilterBank
from fsw.filters.kinds import FILTER_KINDS
from fsw.filters.config import BankConfig
from fsw.filters.linear import LinearFilterBank
from fsw.filters.presets import preset
from fsw.models.environment import Environment


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
        nonlocal it
        z = next(it)
        bank.step(z)

    def reference() -> None:
        nonlocal it
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
    return {
        "name": "linear-bank",
        "ours": t_ours * 1e6,
        "reference": t_ref * 1e6,
        "unit": "us/update",
        "ratio": t_ref / t_ours,
        "filters": N,
        "states": n,
        "measurement_dim": m,
        "reference_impl": "filterpy.kalman.KalmanFilter predict+update",
    }


def _stream(count: int, env: Environment) -> tuple[float, np.ndarray, np.ndarray, tuple, str]:
    """The simulator's InSight approach stream (last 4 days), or the synthetic one without it."""
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


def bench_ekf(config: BankConfig, name: str, stream: tuple, env: Environment, repeat: int = 3) -> dict[str, Any]:
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
    return {
        "name": name,
        "ours": t_ours / k * 1e6,
        "reference": t_ref / k * 1e6,
        "unit": "us/measurement",
        "ratio": t_ref / t_ours,
        "filters": len(config.filters),
        "states": len(FilterBank(config, t0, r0, v0, env=env).state_names),
        "measurements": k,
        "kinds": {kind: sum(1 for m in meas if m.kind == kind) for kind in FILTER_KINDS},
        "reference_impl": "the same filters as separate one-filter banks",
        "stream": label,
    }


def bench_decode(stream: tuple, number: int = 3, repeat: int = 5) -> dict[str, Any]:
    """µs per message: strict ICD decoding of the stream's measurements vs ``json.loads`` alone."""
    from fsw.interface import codec
    from fsw.interface.messages import Measurement

    payloads = [codec.to_json(m) for m in stream[3]]

    def ours() -> None:
        for p in payloads:
            codec.from_json(Measurement, p)

    def reference() -> None:
        for p in payloads:
            _json.loads(p)

    t_ours = t_ref = float("inf")
    for _ in range(repeat):  # interleaved
        t_ours = min(t_ours, _best_of(ours, number, 1) / len(payloads))
        t_ref = min(t_ref, _best_of(reference, number, 1) / len(payloads))
    return {
        "name": "icd-decode",
        "ours": t_ours * 1e6,
        "reference": t_ref * 1e6,
        "unit": "us/message",
        "ratio": t_ref / t_ours,
        "messages_per_s": 1.0 / t_ours,
        "messages": len(payloads),
        "mean_bytes": sum(map(len, payloads)) / max(len(payloads), 1),
        "reference_impl": "json.loads of the same payloads (no validation)",
        "stream": stream[4],
    }


def run_benchmarks(json: bool = False, quick: bool = False, out: IO[str] | None = None) -> list[dict[str, Any]]:
    """Run all benchmarks and print them (text, or one JSON object per line)."""
    out = out if out is not None else sys.stdout
    results: list[dict[str, Any]] = []

    def emit(res: dict[str, Any]) -> None:
        results.append(res)
        if json:
            print(_json.dumps(res), file=out, flush=True)
        else:
            print(f"{res['name']:<12} ours {res['ours']:10.1f} {res['unit']:<15} reference {res['reference']:10.1f}"
                  f"   ratio {res['ratio']:5.2f}x   ({res['reference_impl']})", file=out, flush=True)

    try:
        import filterpy.kalman  # noqa: F401  (the linear bank's reference)
    except ImportError:
        note = ("linear-bank  skipped: its reference, FilterPy, is not installed "
                "(pip install \"navbank[bench]\" or pip install filterpy)")
        print(note, file=sys.stderr if json else out, flush=True)
    else:
        emit(bench_linear(number=100 if quick else 400, repeat=5 if quick else 15))
    env = Environment()
    stream = _stream(120 if quick else 600, env)
    emit(bench_ekf(preset("nominal"), "ekf-bank-3", stream, env, repeat=1 if quick else 3))
    emit(bench_ekf(preset("acs-q"), "ekf-bank-6", stream, env, repeat=1 if quick else 3))
    emit(bench_decode(stream, number=1 if quick else 3, repeat=3 if quick else 7))
    return results

"""Re-processing a measurement set through the flight software's linear filter bank and gating
network, for a bank whose filters differ only in α = [q1 q2 r1 r2] (Chaer et al. 1997 eq. 26).

The filters are ``fsw.filters.linear.LinearFilterBank`` (Chaer et al. 1997 eqs. 2–6) and the gate is
the FSW's ``moe`` network (eqs. 11–20); nothing here filters or gates by itself. The filters of a
bank are independent, so the residual statistics of a bank can be computed in chunks of filters
(in separate processes) and joined; the gate, which couples the filters, then runs once on the
joined records.
"""

from __future__ import annotations

from typing import Callable, Iterable, Iterator, NamedTuple, Sequence

import numpy as np

from fsw.filters.linear import LinearFilterBank
from fsw.filters.record import BankRecord
from fsw.gating import make_network

#: Chaer et al. 1997 §V: Φ, H, x̂₀⁻, P₀⁻ of the 2-state tracking example (eqs. 24–25).
TRANSITION = ((1.0, 1.0), (0.0, 1.0))
MEASUREMENT_MATRIX = ((1.0, 0.0), (0.0, 1.0))
INITIAL_STATE = (0.0, 0.0)
INITIAL_COVARIANCE = ((1000.0, 0.0), (0.0, 1000.0))

#: maps a function over chunks (builtin ``map`` or a process pool's)
Mapper = Callable[[Callable[..., "ResidualChunk"], Iterable[np.ndarray], Iterable[np.ndarray]], Iterator["ResidualChunk"]]


class ResidualChunk(NamedTuple):
    """Residual statistics of some filters over a whole measurement set (K measurements, N filters)."""

    residual: np.ndarray  # (K, N, m)
    S: np.ndarray  # (K, N, m, m)
    chi2: np.ndarray  # (K, N)
    processed: np.ndarray  # (K, N) bool


def _check(z: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    z = np.asarray(z, dtype=float)
    alpha = np.atleast_2d(np.asarray(alpha, dtype=float))
    if z.ndim != 2 or z.shape[1] != 2 or z.shape[0] < 1:
        raise ValueError(f"the measurement set must be (K, 2) [range, velocity], got shape {z.shape}")
    if alpha.shape[1] != 4 or not np.all(np.isfinite(alpha)) or np.any(alpha < 0.0):
        raise ValueError("each parameter vector must be 4 finite non-negative variances [q1 q2 r1 r2]")
    if not np.all(np.isfinite(z)):
        raise ValueError("the measurement set holds non-finite values")
    return z, alpha


def residual_chunk(z: np.ndarray, alpha: np.ndarray) -> ResidualChunk:
    """Run the FSW's linear bank with one filter per row α = [q1 q2 r1 r2] over ``z`` (Chaer et al. 1997
    eqs. 2–6): measurement 1 updates the a-priori state, every later one follows one transition step."""
    z, alpha = _check(z, alpha)
    n_f = len(alpha)
    Q = np.zeros((n_f, 2, 2))
    R = np.zeros((n_f, 2, 2))
    Q[:, 0, 0], Q[:, 1, 1], R[:, 0, 0], R[:, 1, 1] = alpha.T
    bank = LinearFilterBank([f"F{i}" for i in range(n_f)], TRANSITION, Q, MEASUREMENT_MATRIX, R,
                            INITIAL_STATE, INITIAL_COVARIANCE)
    K = len(z)
    res = np.empty((K, n_f, 2))
    S = np.empty((K, n_f, 2, 2))
    chi2 = np.empty((K, n_f))
    proc = np.empty((K, n_f), dtype=bool)
    for k in range(K):
        rec = bank.update(z[k], t=float(k), seq=k) if k == 0 else bank.step(z[k], t=float(k), seq=k)
        res[k], S[k], chi2[k], proc[k] = rec.residual, rec.S, rec.chi2, rec.processed
    return ResidualChunk(res, S, chi2, proc)


def bank_records(z: np.ndarray, alpha: np.ndarray, *, mapper: Mapper = map, chunks: int = 1,
                 names: Sequence[str] | None = None) -> list[BankRecord]:
    """The bank's per-measurement records for filters α (rows), computed in ``chunks`` groups of
    filters through ``mapper`` (e.g. a process pool's map) and joined in bank order."""
    z, alpha = _check(z, alpha)
    n_f = len(alpha)
    parts = [p for p in np.array_split(alpha, max(1, min(int(chunks), n_f))) if len(p)]
    got = list(mapper(residual_chunk, [z] * len(parts), parts))
    res = np.concatenate([g.residual for g in got], axis=1)
    S = np.concatenate([g.S for g in got], axis=1)
    chi2 = np.concatenate([g.chi2 for g in got], axis=1)
    proc = np.concatenate([g.processed for g in got], axis=1)
    filters = tuple(names) if names is not None else tuple(f"F{i + 1}" for i in range(n_f))
    return [BankRecord(float(k), k, "generic-linear", filters, res[k], S[k], chi2[k], proc[k])
            for k in range(len(z))]


def gate_weights(records: list[BankRecord], eta: float = 1.0) -> np.ndarray:
    """(K, N) weights of the FSW's ``moe`` gate (Chaer et al. 1997 eqs. 11–20, learning rate η) after
    each measurement."""
    net = make_network("moe", records[0].filters, {"eta": float(eta)})
    rows = []
    for r in records:
        upd = net.update(r)
        if upd is None:
            raise ValueError(f"the gate gave no weights after measurement {r.seq}")
        rows.append(upd.weights)
    return np.array(rows)


def log_likelihood(z: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Σ_k ln N(z̄_k; 0, S_k) per filter: the log-likelihood of the measurement set under each α
    (the objective of Chaer et al. 1997 eqs. 21–23, unconstrained)."""
    recs = bank_records(z, alpha)
    return np.sum([r.log_likelihood() for r in recs], axis=0)

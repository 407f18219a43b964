"""Navigation quality of a run from its telemetry: pre-fit residuals per kind and station, NIS
statistics, and B-plane targeting against truth.

The residuals are the FSW's own (``Residuals``: what the bank computed for the gating); the
truth B-plane is computed on the ground from the recorded truth with the FSW's B-plane model
(:mod:`fsw.models.bplane`) at the epochs of the estimates' B-plane messages.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from fsw.interface import messages as m
from fsw.models.bplane import NotHyperbolic, bplane_values


def _sample_array(field: str, dtype: type) -> cached_property[np.ndarray]:
    """A :class:`ResidualTrace` array of one sample field, built when first read."""
    def build(trace: ResidualTrace) -> np.ndarray:
        return _stacked([getattr(s, field) for s in trace._samples], dtype)
    return cached_property(build)


class ResidualTrace:
    """Residuals of one measurement kind from one station/target, in time order; arrays (M
    samples, N filters, n components), each built from the samples when first read (the run
    summary, which every run and campaign task computes, reads only the NIS)."""

    def __init__(self, kind: str, source: str, filters: tuple[str, ...], samples: list[m.ResidualSample]):
        self.kind = kind
        self.source = source
        self.filters = filters
        self._samples = samples

    @cached_property
    def t_s(self) -> np.ndarray:
        return np.array([s.t_s for s in self._samples])

    residual = _sample_array("residual", float)
    sigma = _sample_array("sigma", float)
    normalised = _sample_array("normalised", float)
    nis = _sample_array("nis", float)
    processed = _sample_array("processed", bool)

    @property
    def dimension(self) -> int:
        """Components n of the measurement (the residual's last axis)."""
        return int(self.residual.shape[2]) if "residual" in self.__dict__ else len(self._samples[0].residual[0])


@dataclass
class BPlaneTrace:
    """B-plane history of one estimate label, with truth where the recording has it (NaN otherwise)."""

    label: str
    t_s: np.ndarray
    b_dot_r: np.ndarray
    b_dot_t: np.ndarray
    cov: np.ndarray  # (M, 2, 2) km²
    periapsis_s: np.ndarray
    periapsis_sigma_s: np.ndarray
    true_b_dot_r: np.ndarray
    true_b_dot_t: np.ndarray
    true_periapsis_s: np.ndarray


def residual_traces(messages: list[m.Residuals]) -> dict[tuple[str, str], ResidualTrace]:
    """Residual samples grouped by (kind, source), in time order."""
    groups: dict[tuple[str, str], list[m.ResidualSample]] = defaultdict(list)
    filters: tuple[str, ...] = ()
    for msg in messages:
        filters = filters or msg.filters
        if msg.filters != filters:
            continue  # a bank cannot change its filters within a run; such a message is not ours to plot
        for s in msg.samples:
            groups[(s.kind, s.source)].append(s)
    out = {}
    for key, samples in sorted(groups.items()):
        samples.sort(key=lambda s: s.t_s)
        out[key] = ResidualTrace(key[0], key[1], filters, samples)
    return out


def _stacked(rows: list[Any], dtype: type) -> np.ndarray:
    """``np.array(rows, dtype)`` of M equally shaped rows — of N values, or of N sequences of n
    values — from one flat list: numpy's discovery of the shape of 10⁴ nested tuples costs ten
    times the conversion. Rows that are not all alike (a malformed recording) take numpy's own
    path, and get its result or its error."""
    try:
        M, N = len(rows), len(rows[0])
        if N and isinstance(rows[0][0], (tuple, list)):
            n = len(rows[0][0])
            flat = [v for row in rows if len(row) == N for comp in row if len(comp) == n for v in comp]
            shape: tuple[int, ...] = (M, N, n)
        else:
            flat = [v for row in rows if len(row) == N for v in row]
            shape = (M, N)
        arr: np.ndarray = np.array(flat, dtype=dtype)
        if arr.shape == (math.prod(shape),):
            return arr.reshape(shape)
    except (TypeError, ValueError, IndexError):
        pass
    return np.array(rows, dtype=dtype)


def nis_statistics(traces: dict[tuple[str, str], ResidualTrace]) -> dict[str, dict[str, dict[str, float]]]:
    """Per kind and filter: mean NIS of the measurements the filter processed against its expected
    value n (the kind's dimension), and the fraction outside the two-sided 95 % chi-square bounds."""
    if not traces:
        return {}  # without importing scipy.stats (0.3 s; the run summary has no residuals)
    from scipy.stats import chi2

    by_kind: dict[str, list[ResidualTrace]] = defaultdict(list)
    for tr in traces.values():
        by_kind[tr.kind].append(tr)
    out: dict[str, dict[str, dict[str, float]]] = {}
    for kind, trs in sorted(by_kind.items()):
        n = trs[0].dimension
        lo, hi = chi2.ppf(0.025, n), chi2.ppf(0.975, n)
        out[kind] = {}
        for i, name in enumerate(trs[0].filters):
            vals = np.concatenate([tr.nis[tr.processed[:, i], i] for tr in trs])
            if vals.size == 0:
                continue
            out[kind][name] = {"count": float(vals.size), "dimension": float(n), "mean_nis": float(np.mean(vals)),
                               "outside_95": float(np.mean((vals < lo) | (vals > hi)))}
    return out


def _key(t_s: float) -> float:
    return round(float(t_s), 3)


def bplane_traces(by_label: dict[str, list[m.BPlane]], truth: list[m.Truth]) -> dict[str, BPlaneTrace]:
    """B-plane history per estimate label, each epoch paired with the truth recorded at it."""
    states = {_key(t.t_s): t for t in truth}
    true_cache: dict[float, tuple[float, float, float]] = {}

    def true_at(t_s: float) -> tuple[float, float, float]:
        k = _key(t_s)
        if k not in true_cache:
            tr = states.get(k)
            val = (np.nan, np.nan, np.nan)
            if tr is not None:
                try:
                    v = bplane_values(np.array(tr.position_km), np.array(tr.velocity_km_s))
                    val = (float(v[0]), float(v[1]), float(t_s + v[2]))
                except NotHyperbolic:
                    pass
            true_cache[k] = val
        return true_cache[k]

    out = {}
    for label, msgs in sorted(by_label.items()):
        msgs = sorted(msgs, key=lambda b: b.t_s)
        truth_rows = np.array([true_at(b.t_s) for b in msgs], dtype=float).reshape(-1, 3)
        out[label] = BPlaneTrace(
            label=label, t_s=np.array([b.t_s for b in msgs]), b_dot_r=np.array([b.b_dot_r_km for b in msgs]),
            b_dot_t=np.array([b.b_dot_t_km for b in msgs]),
            cov=np.array([b.covariance_km2 for b in msgs], dtype=float).reshape(-1, 2, 2),
            periapsis_s=np.array([b.periapsis_s for b in msgs]),
            periapsis_sigma_s=np.array([b.periapsis_sigma_s for b in msgs]),
            true_b_dot_r=truth_rows[:, 0], true_b_dot_t=truth_rows[:, 1], true_periapsis_s=truth_rows[:, 2],
        )
    return out


def bplane_final(traces: dict[str, BPlaneTrace]) -> dict[str, dict[str, Any]]:
    """The numbers a Mars-approach navigator reports, at each label's last B-plane epoch: B·R,
    B·T, their 1σ, the errors against truth, and the closest-approach time error and 1σ."""
    out: dict[str, dict[str, Any]] = {}
    for label, tr in traces.items():
        if not len(tr.t_s):
            continue
        i = -1
        out[label] = {
            "t_s": float(tr.t_s[i]), "b_dot_r_km": float(tr.b_dot_r[i]), "b_dot_t_km": float(tr.b_dot_t[i]),
            "b_dot_r_sigma_km": float(np.sqrt(max(tr.cov[i, 0, 0], 0.0))),
            "b_dot_t_sigma_km": float(np.sqrt(max(tr.cov[i, 1, 1], 0.0))),
            "b_dot_r_error_km": float(tr.b_dot_r[i] - tr.true_b_dot_r[i]),
            "b_dot_t_error_km": float(tr.b_dot_t[i] - tr.true_b_dot_t[i]),
            "periapsis_error_s": float(tr.periapsis_s[i] - tr.true_periapsis_s[i]),
            "periapsis_sigma_s": float(tr.periapsis_sigma_s[i]),
        }
    return out

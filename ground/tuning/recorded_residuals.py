"""What EM needs from a recorded run, recomputed on the ground: the per-filter residual
log-densities ln f(z_k | α_{j|i}) (Chaer et al. 1998 eq. 7) of every measurement the bank processed.

The recording does not carry them (``FilterWeights`` holds weights, not likelihoods), so the
recorded measurements are flown again through the FSW of the recorded configuration
(``ground.replay.rerun``, the same code as ``navbank replay --rerun``) and the bank's records are
tapped as the core computes them. The re-run's own hierarchical weights (the online gradient-ascent
learning of eqs. 15–16) come with them, to find the switch and to compare with EM.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from fsw.core import FswCore
from fsw.filters.record import BankRecord
from fsw.gating.magill import gaussian_log_likelihood
from fsw.interface import topics
from fsw.interface.messages import FilterWeights
from ground.replay.fsw_config import load_fsw_config
from ground.replay.recording import run_info
from ground.replay.rerun import recorded_commands, recorded_measurement_stream, rerun_fsw


@dataclass
class HierarchyData:
    t_s: np.ndarray  # (N,) measurement epochs
    banks: list[str]
    bank_filters: dict[str, list[str]]
    log_f: list[np.ndarray]  # per bank (N, L_i): ln f(z_k | α_{j|i})
    online_top: np.ndarray  # (N, K): g_i after measurement k (gradient ascent)
    online_in: list[np.ndarray]  # per bank (N, L_i): g_{j|i} after measurement k


def hierarchical_groups(config, network: str = "hierarchical") -> dict[str, list[str]]:
    for g in config.gating:
        if g.network == network:
            groups = dict(g.params.groups)
            return {b: list(f) for b, f in groups.items()} if groups else {"bank": list(config_filter_names(config))}
    raise ValueError(f"the recorded configuration has no {network!r} gating network")


def config_filter_names(config) -> list[str]:
    return [f.name for f in config.bank.filters]


def recorded_hierarchy(path: str | os.PathLike, network: str = "hierarchical") -> HierarchyData:
    """Re-run the recording's FSW and collect each processed measurement's log-densities by bank."""
    info = run_info(path)
    if info.config_text is None:
        raise ValueError(f"{info.path}: no configuration attached (runs recorded by `navbank run` carry config.yaml)")
    config = load_fsw_config(info.config_text, f"{info.path}:{info.config_name}")
    groups = hierarchical_groups(config, network)
    stream, _ = recorded_measurement_stream(path)
    if not stream:
        raise ValueError(f"{info.path}: no /sim/measurements recorded")
    records: list[BankRecord] = []

    def tap(core: FswCore) -> None:
        core.record_taps = (records.append,)

    res = rerun_fsw(config, stream, run_id=info.run_id or "rerun", commands=recorded_commands(path), observe=tap)
    wtopic = f"{topics.FSW_WEIGHTS}/{network}"
    online = [m for t, m in res.outputs if t == wtopic and isinstance(m, FilterWeights)]
    if not records:
        raise ValueError(f"{info.path}: the bank processed no measurement")
    if len(online) != len(records):
        raise ValueError(f"{len(records)} bank records but {len(online)} {network} weight updates")
    names = list(records[0].filters)
    col = {n: i for i, n in enumerate(names)}
    ll = np.array([gaussian_log_likelihood(r) for r in records])  # (N, filters)
    banks = list(groups)
    W = np.array([m.weights for m in online])
    top = np.array([[m.groups.get(b, 0.0) for b in banks] for m in online])
    log_f, online_in = [], []
    for i, b in enumerate(banks):
        idx = [col[f] for f in groups[b]]
        log_f.append(ll[:, idx])
        online_in.append(W[:, idx] / np.maximum(top[:, i:i + 1], 1e-300))
    return HierarchyData(np.array([r.t for r in records]), banks, groups, log_f, top, online_in)


def switch_index(top: np.ndarray) -> int | None:
    """The measurement from which the online top-level gate's leading bank stays the one it ends
    on (Chaer et al. 1998 §V: the data are divided at the switch the gradient-ascent gate shows);
    None if it never changes after the first tenth of the set."""
    lead = np.argmax(top, axis=1)
    other = np.flatnonzero(lead != lead[-1])
    if other.size == 0:
        return None
    k = int(other[-1]) + 1
    return k if k > len(lead) // 10 else None

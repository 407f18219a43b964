"""Characterization decision tree: which filter families do the weights prefer?

Lubey & Ely 2022 §4.3–4.4 characterise anomalies by hand from the chi-square network's weights; this is
that reasoning made automatic. Preference is measured as the *excess* weight over the nominal
band, e = w − mu, so a network whose nominal weights are not uniform (Magill prefers the fused
filter) is judged against its own normal. The tree:

1. **Dynamics** (only when the bank holds high-Q/low-Q pairs of the same measurement family):
   the high-Q variants gain weight over their low-Q counterparts (contrast
   a = Σ_f (1_{Q,f}/|Q_f| − 1_{L,f}/|L_f|)). Checked first because a dynamics fault also moves
   the measurement families (Lubey & Ely 2022 Table 4: the optical filters gain weight under thruster
   mis-modeling), whereas a measurement fault moves both variants of a family together.
2. **Radio-only preferred** (largest family excess, margin over the runner-up) →
   ``optical-measurement`` (Lubey & Ely 2022 Table 3, optical bias: radio 0.90, optical 0.06, fused 0.04).
3. **Optical-only preferred** → ``radiometric-measurement`` (clock/range; Table 3, large radio
   bias: optical 0.39 vs 0.30).
4. Otherwise ``unknown`` (no significant preference, or the fused filters preferred).

A node names its class only if its margin m is at least ``min_margin`` (weight) and at least
``min_margin_z`` times the margin's nominal standard deviation σ_m = sqrt(aᵀ C a). Its confidence
is erf(m / (√2 σ_m)) = P(|N(0, σ_m²)| < m): how unlikely the margin is under nominal scatter. An
``unknown`` class carries 1 − the largest such confidence among the named classes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from fsw.fdir.families import FUSED, OPTICAL, RADIO, FilterFamily
from fsw.fdir.statistic import NominalBand

CLASS_BY_PREFERRED_GROUP = {RADIO: "optical-measurement", OPTICAL: "radiometric-measurement"}


@dataclass(frozen=True)
class Characterization:
    """Outcome of the decision tree, with the margins behind it."""

    anomaly_class: str
    confidence: float
    dynamics_margin: float | None
    preferred_group: str | None
    group_margin: float | None
    group_excess: dict[str, float] = field(default_factory=dict)


def _confidence(margin: float, sigma: float) -> float:
    if margin <= 0.0:
        return 0.0
    if sigma <= 0.0:
        return 1.0
    return math.erf(margin / (math.sqrt(2.0) * sigma))


def _significant(margin: float, sigma: float, min_margin: float, min_margin_z: float) -> bool:
    return margin > 0.0 and margin >= min_margin and margin >= min_margin_z * sigma


def dynamics_contrast(families: Sequence[FilterFamily], active: np.ndarray) -> np.ndarray | None:
    """Contrast vector 'high-Q minus low-Q within each measurement family', or None if the bank
    holds no active high-Q/low-Q pair."""
    a = np.zeros(len(families))
    paired = False
    keys = {fam.processes for fam in families}
    for key in keys:
        hi = [i for i, f in enumerate(families) if f.processes == key and f.high_q and active[i]]
        lo = [i for i, f in enumerate(families) if f.processes == key and not f.high_q and active[i]]
        if hi and lo:
            paired = True
            a[hi] += 1.0 / len(hi)
            a[lo] -= 1.0 / len(lo)
    return a if paired else None


def characterize(
    weights: np.ndarray,
    band: NominalBand,
    families: Sequence[FilterFamily],
    min_margin: float,
    min_margin_z: float,
    active: np.ndarray | None = None,
) -> Characterization:
    """Run the decision tree on a weight vector (ordered like ``families`` and ``band``).

    With ``active`` given, ``weights`` and ``band`` cover only the active filters (in order).
    """
    fams = list(families)
    act = np.ones(len(fams), dtype=bool) if active is None else np.asarray(active, dtype=bool)
    fams = [f for f, a in zip(fams, act) if a]
    on = np.ones(len(fams), dtype=bool)
    e = np.asarray(weights, dtype=float) - band.mean

    conf_dyn = 0.0
    m_dyn: float | None = None
    a_dyn = dynamics_contrast(fams, on)
    if a_dyn is not None:
        m_dyn = float(a_dyn @ e)
        s_dyn = band.contrast_sigma(a_dyn)
        conf_dyn = _confidence(m_dyn, s_dyn)
        if _significant(m_dyn, s_dyn, min_margin, min_margin_z):
            return Characterization("dynamics", conf_dyn, m_dyn, None, None, {})

    members = {g: np.array([f.group == g for f in fams]) for g in (RADIO, OPTICAL, FUSED)}
    members = {g: m for g, m in members.items() if m.any()}
    excess = {g: float(e[m].sum()) for g, m in members.items()}
    best_conf = conf_dyn
    if len(members) >= 2:
        for g in (RADIO, OPTICAL):
            if g not in members:
                continue
            rival = max((h for h in members if h != g), key=lambda h: excess[h])
            margin = excess[g] - excess[rival]
            sigma = band.contrast_sigma(members[g].astype(float) - members[rival].astype(float))
            conf = _confidence(margin, sigma)
            if _significant(margin, sigma, min_margin, min_margin_z):
                return Characterization(CLASS_BY_PREFERRED_GROUP[g], conf, m_dyn, g, margin, excess)
            best_conf = max(best_conf, conf)
    ranked = sorted(excess, key=lambda g: excess[g], reverse=True)
    preferred = ranked[0] if ranked else None
    margin_top = excess[ranked[0]] - excess[ranked[1]] if len(ranked) >= 2 else None
    return Characterization("unknown", 1.0 - best_conf, m_dyn, preferred, margin_top, excess)

"""Synthetic gating-weight histories for the anomaly-detector tests, and checks of the generator.

Weights come from an independent implementation of the chi-square gating network's closed-form
update (Lubey & Ely 2022 eq. 8) driven by synthetic batch chi-square sums: each batch holds ``M_RADIO``
scalar radiometric and ``M_OPTICAL`` two-dimensional optical measurements; a filter that does not
process a type contributes the chi-square mean n_j for it (Lubey & Ely 2022 §3.2); a fault adds a
noncentrality to the sums of the filters it affects.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from fsw.fdir.families import OPTICAL, RADIO, FilterFamily

M_RADIO, M_OPTICAL = 600, 200
SIGMA_W = 0.05

BANK3 = (
    FilterFamily(name="radio", families=("radio",)),
    FilterFamily(name="optical", families=("optical",)),
    FilterFamily(name="fused", families=("fused",)),
)
BANK6 = BANK3 + (
    FilterFamily(name="radio-Q", families=("radio",), high_q=True),
    FilterFamily(name="optical-Q", families=("optical",), high_q=True),
    FilterFamily(name="fused-Q", families=("radio", "optical"), high_q=True),
)


def names(bank) -> tuple[str, ...]:
    return tuple(f.name for f in bank)


def chi2_gating_step(p_prev: np.ndarray, G: np.ndarray, sigma_w: float = SIGMA_W) -> np.ndarray:
    """Lubey & Ely 2022 eq. 8 with W = sigma_w^2 I (G diagonal), vectorised over leading axes."""
    winv = 1.0 / sigma_w**2
    a = 1.0 / (G + winv)
    lam = (np.sum(a * winv * p_prev, axis=-1) - 1.0) / np.sum(a, axis=-1)
    return a * (winv * p_prev - lam[..., None])


def batch_chi2(rng, bank, n_runs: int, nonc_radio: np.ndarray, nonc_optical: np.ndarray) -> np.ndarray:
    """Batch sums G (n_runs, N); nonc_* are per-filter noncentralities of the two data types."""
    out = np.empty((n_runs, len(bank)))
    for i, fam in enumerate(bank):
        g = np.zeros(n_runs)
        for kind, m, n_j, nonc in ((RADIO, M_RADIO, 1, nonc_radio[i]), (OPTICAL, M_OPTICAL, 2, nonc_optical[i])):
            dof = m * n_j
            if kind not in fam.processes:
                g += dof
            elif nonc > 0.0:
                g += rng.noncentral_chisquare(dof, nonc, n_runs)
            else:
                g += rng.chisquare(dof, n_runs)
        out[:, i] = g
    return out


def simulate_chi2(rng, bank, n_runs: int, n_batches: int, fault=None, onset: int = 0, end: int | None = None):
    """Weights (n_runs, n_batches, N). ``fault(fam) -> (nonc_radio, nonc_optical)`` applies to
    batches onset <= k < end."""
    n = len(bank)
    zeros = np.zeros(n)
    if fault is not None:
        nr = np.array([fault(f)[0] for f in bank])
        no = np.array([fault(f)[1] for f in bank])
    p = np.full((n_runs, n), 1.0 / n)
    out = np.empty((n_runs, n_batches, n))
    for k in range(n_batches):
        active = fault is not None and k >= onset and (end is None or k < end)
        G = batch_chi2(rng, bank, n_runs, nr if active else zeros, no if active else zeros)
        p = chi2_gating_step(p, G)
        out[:, k] = p
    return out


def optical_bias(nonc: float):
    return lambda f: (0.0, nonc if OPTICAL in f.processes else 0.0)


def radio_bias(nonc: float):
    return lambda f: (nonc if RADIO in f.processes else 0.0, 0.0)


def thruster_mismodel(nonc_radio: float, nonc_optical: float):
    """Lubey & Ely 2022 §4.4: low-Q filters mis-model the thrusting, radio-based ones far more."""
    return lambda f: (0.0, 0.0) if f.high_q else (
        nonc_radio if RADIO in f.processes else 0.0,
        nonc_optical if OPTICAL in f.processes else 0.0,
    )


def ramp_weights(rng, n_batches, nominal, faulty, onset, tau=1.5, noise=0.008, end=None, recover_tau=1.5):
    """Weights that sit at ``nominal`` (+ zero-sum noise), approach ``faulty`` from ``onset`` with
    time constant tau, and, if ``end`` is given, return to nominal afterwards."""
    nominal = np.asarray(nominal, float)
    faulty = np.asarray(faulty, float)
    k = np.arange(n_batches)
    rise = np.where(k >= onset, 1.0 - np.exp(-(k - onset + 1) / tau), 0.0)
    if end is not None:
        level_at_end = 1.0 - np.exp(-(end - onset) / tau)
        fall = np.exp(-(k - end + 1) / recover_tau)
        rise = np.where(k >= end, level_at_end * fall, rise)
    w = nominal + rise[:, None] * (faulty - nominal)
    e = rng.normal(0.0, noise, w.shape)
    w = np.clip(w + e - e.mean(axis=1, keepdims=True), 1e-6, None)
    return w / w.sum(axis=1, keepdims=True)


# -- checks of the generator itself ---------------------------------------------------------------


def test_eq8_step_minimises_eq6_cost():
    """The closed form used to synthesise weights is the constrained minimum of Lubey & Ely 2022 eq. 6."""
    rng = np.random.default_rng(7)
    p_prev = rng.dirichlet(np.ones(4))
    G = rng.uniform(50.0, 3000.0, 4)
    winv = 1.0 / SIGMA_W**2

    def cost(p):
        return 0.5 * p @ (G * p) + 0.5 * winv * np.sum((p - p_prev) ** 2)

    res = minimize(cost, np.full(4, 0.25), constraints=[{"type": "eq", "fun": lambda p: p.sum() - 1.0}],
                   method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})
    np.testing.assert_allclose(chi2_gating_step(p_prev, G), res.x, atol=1e-7)


def test_nominal_weights_stay_equal_and_optical_bias_prefers_radio():
    rng = np.random.default_rng(3)
    nominal = simulate_chi2(rng, BANK3, 200, 40)
    assert np.allclose(nominal.sum(axis=-1), 1.0)
    np.testing.assert_allclose(nominal[:, 5:].mean(axis=(0, 1)), 1 / 3, atol=2e-3)
    biased = simulate_chi2(rng, BANK3, 50, 40, fault=optical_bias(20000.0))
    mean = biased[:, 20:].mean(axis=(0, 1))
    assert mean[0] > 0.8 and mean[1] < 0.15 and mean[2] < 0.15  # Lubey & Ely 2022 Table 3, medium optical


@pytest.mark.parametrize("tau", [1.0, 3.0])
def test_ramp_weights_reach_target(tau):
    rng = np.random.default_rng(0)
    w = ramp_weights(rng, 60, [1 / 3] * 3, [0.9, 0.05, 0.05], onset=20, tau=tau, noise=0.0)
    np.testing.assert_allclose(w[:20], 1 / 3)
    np.testing.assert_allclose(w[-1], [0.9, 0.05, 0.05], atol=1e-6)

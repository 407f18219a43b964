"""Decision tree on the average weights of Lubey & Ely 2022 Tables 3 and 4 (hand-worked margins)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fsw.fdir.characterize import characterize, dynamics_contrast
from fsw.fdir.families import FilterFamily
from fsw.fdir.statistic import NominalBand
from test_fdir_synthetic import BANK3, BANK6

SIGMA = 0.01


def band(n: int, mean=None) -> NominalBand:
    cov = SIGMA**2 * (np.eye(n) - np.ones((n, n)) / n) + 1e-6 * np.eye(n)
    return NominalBand(np.full(n, 1.0 / n) if mean is None else np.asarray(mean, float), cov)


TABLE3 = [  # radio, optical, fused
    ("Small Bias—Optical", [0.4186, 0.2923, 0.2891], "optical-measurement"),
    ("Medium Bias—Optical", [0.9008, 0.0638, 0.0354], "optical-measurement"),
    ("Large Bias—Optical", [0.9679, 0.0316, 0.0004], "optical-measurement"),
    ("Large Bias—Radio", [0.3047, 0.3899, 0.3054], "radiometric-measurement"),
    ("No Bias", [0.3354, 0.3272, 0.3374], "unknown"),
]


@pytest.mark.parametrize("case, w, expected", TABLE3, ids=[c[0] for c in TABLE3])
def test_table3_cases(case, w, expected):
    out = characterize(np.array(w), band(3), BANK3, min_margin=0.02, min_margin_z=2.0)
    assert out.anomaly_class == expected


def test_large_radio_bias_margin_and_confidence_by_hand():
    w = np.array([0.3047, 0.3899, 0.3054])
    out = characterize(w, band(3), BANK3, min_margin=0.02, min_margin_z=2.0)
    # optical excess 0.3899-1/3, best rival fused 0.3054-1/3: margin 0.0845
    assert out.group_margin == pytest.approx(0.3899 - 0.3054, abs=1e-12)
    # var(w_opt - w_fused) = 2 (sigma^2 (1 - 1/3) + 1e-6) + 2 sigma^2/3
    sd = math.sqrt(2 * (SIGMA**2 * 2 / 3 + 1e-6) + 2 * SIGMA**2 / 3)
    assert out.confidence == pytest.approx(math.erf(0.0845 / (math.sqrt(2) * sd)), rel=1e-9)


TABLE4 = [  # radio, optical, fused, radio-Q, optical-Q, fused-Q
    ("Attitude Thruster", [0.0844, 0.2510, 0.0815, 0.1658, 0.2520, 0.1653]),
    ("Process Noise", [0.0961, 0.1992, 0.0742, 0.1945, 0.2431, 0.1929]),
]


@pytest.mark.parametrize("case, w", TABLE4, ids=[c[0] for c in TABLE4])
def test_table4_cases_are_dynamics(case, w):
    out = characterize(np.array(w), band(6), BANK6, min_margin=0.02, min_margin_z=2.0)
    assert out.anomaly_class == "dynamics"
    hi, lo = np.array(w)[3:].sum(), np.array(w)[:3].sum()
    assert out.dynamics_margin == pytest.approx((hi - lo) / 1.0, abs=1e-12)
    assert out.confidence > 0.99


def test_measurement_fault_in_dynamics_bank_is_not_dynamics():
    """Both variants of the radio family gain together under an optical bias."""
    w = np.array([0.45, 0.03, 0.02, 0.45, 0.03, 0.02])
    out = characterize(w, band(6), BANK6, min_margin=0.02, min_margin_z=2.0)
    assert out.anomaly_class == "optical-measurement"
    assert out.dynamics_margin == pytest.approx(0.0, abs=1e-12)


def test_nominal_band_not_uniform():
    """Magill-like nominal (fused dominant): a fused weight of 0.9 is normal, not a preference."""
    nominal = [0.05, 0.05, 0.90]
    b = band(3, nominal)
    at_nominal = characterize(np.array([0.05, 0.05, 0.90]), b, BANK3, 0.02, 2.0)
    assert at_nominal.anomaly_class == "unknown" and at_nominal.group_margin == pytest.approx(0.0)
    out = characterize(np.array([0.30, 0.04, 0.66]), b, BANK3, 0.02, 2.0)
    assert out.anomaly_class == "optical-measurement"


def test_insignificant_margin_is_unknown_with_complementary_confidence():
    w = np.array([1 / 3 + 0.012, 1 / 3 - 0.006, 1 / 3 - 0.006])  # margin 0.018 < min_margin
    out = characterize(w, band(3), BANK3, min_margin=0.02, min_margin_z=0.0)
    assert out.anomaly_class == "unknown"
    sd = math.sqrt(2 * (SIGMA**2 * 2 / 3 + 1e-6) + 2 * SIGMA**2 / 3)
    assert out.confidence == pytest.approx(1.0 - math.erf(0.018 / (math.sqrt(2) * sd)), rel=1e-9)


def test_dynamics_contrast_pairs_by_family_tags():
    bank = (
        FilterFamily(name="a", families=("radio",)),
        FilterFamily(name="b", families=("radio",), high_q=True),
        FilterFamily(name="c", families=("radio",), high_q=True),
        FilterFamily(name="d", families=("optical",), high_q=True),  # no low-Q optical: unpaired
    )
    a = dynamics_contrast(bank, np.ones(4, dtype=bool))
    np.testing.assert_allclose(a, [-1.0, 0.5, 0.5, 0.0])
    assert dynamics_contrast(BANK3, np.ones(3, dtype=bool)) is None
    assert dynamics_contrast(bank, np.array([False, True, True, True])) is None


def test_fused_tag_equals_radio_plus_optical():
    assert FilterFamily(name="x", families=("fused",)).group == "fused"
    assert FilterFamily(name="y", families=("optical", "radio")).group == "fused"
    assert FilterFamily(name="z", families=("lidar",)).group == "other"
    with pytest.raises(ValueError):
        FilterFamily(name="w", families=())

"""Clopper–Pearson intervals against scipy's exact binomial interval."""

import pytest
from scipy import stats

from ground.report.intervals import clopper_pearson


@pytest.mark.parametrize("k, n", [(0, 10), (3, 10), (10, 10), (1, 400)])
def test_clopper_pearson_matches_scipy(k, n):
    lo, hi = clopper_pearson(k, n, 0.95)
    ref = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    assert lo == pytest.approx(ref.low, abs=1e-12) and hi == pytest.approx(ref.high, abs=1e-12)


def test_no_interval_without_trials():
    with pytest.raises(ValueError):
        clopper_pearson(0, 0)

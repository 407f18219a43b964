"""A filter estimate's σ and RTPC, checked against numpy's own reductions of the covariance."""

import math

import numpy as np

from fsw.filters.estimate import FilterEstimate


def _estimate(P: np.ndarray) -> FilterEstimate:
    n = P.shape[0]
    return FilterEstimate("f", 0.0, tuple(f"s{k}" for k in range(n)), np.zeros(n), P)


def test_sigma_and_rtpc_are_numpys_to_the_bit():
    """σ = √max(diag P, 0) and RTPC = √max(tr P_rr, 0) are formed without numpy's clip and trace
    wrappers: the values (and signs of zero) must be theirs, also for negative, zero and
    non-finite diagonals."""
    rng = np.random.default_rng(11)
    specials = [0.0, -0.0, -1.0, np.nan, np.inf, 5e-324]
    for trial in range(3000):
        n = int(rng.integers(3, 17))
        A = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-6, 6)
        P = A @ A.T
        if trial % 3 == 0:
            for _ in range(int(rng.integers(1, 4))):
                k = int(rng.integers(3))
                P[k, k] = specials[int(rng.integers(len(specials)))]
        est = _estimate(P)
        want_sigma = np.sqrt(np.clip(np.diag(P), 0.0, None))
        assert np.array_equal(est.sigma, want_sigma, equal_nan=True)
        assert np.array_equal(np.signbit(est.sigma), np.signbit(want_sigma))
        with np.errstate(invalid="ignore"):
            want_rtpc = float(math.sqrt(max(np.trace(P[0:3, 0:3]), 0.0)))
        got = est.position_sigma_km
        assert type(got) is float
        assert (got == want_rtpc or (math.isnan(got) and math.isnan(want_rtpc))) and math.copysign(1, got) == math.copysign(1, want_rtpc)
    # three negative zeros: numpy's trace adds them to 0.0
    assert math.copysign(1.0, _estimate(np.diag([-0.0, -0.0, -0.0])).position_sigma_km) == 1.0
    assert _estimate(np.diag([4.0, 9.0, 12.0, 1.0])).position_sigma_km == 5.0

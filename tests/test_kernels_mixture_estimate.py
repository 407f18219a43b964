"""The compiled weighted-sum estimate (Chaer et al. 1997 eq. 3) against numpy's einsum form and
against the mixture moments computed apart."""

import numpy as np
import pytest

from fsw.filters.combine import weighted_estimate
from fsw.kernels.mixture_estimate import mixture_estimate


def _case(rng, N, n):
    x = rng.standard_normal((N, n)) * 10.0 ** rng.uniform(-3, 6, n)
    A = rng.standard_normal((N, n, n))
    P = np.ascontiguousarray(A @ A.transpose(0, 2, 1) * 10.0 ** rng.uniform(-4, 4))
    used = rng.random(N) < 0.7
    used[rng.integers(N)] = True
    w = np.where(used, rng.random(N) + 0.01, 0.0)
    w /= w.sum()
    cols = np.flatnonzero(rng.random(n) < 0.8)
    return x, P, w, np.flatnonzero(used), cols if cols.size else np.arange(n)


def _kernel(x, P, w, rows, cols):
    x_out, P_out = np.empty(cols.size), np.empty((cols.size, cols.size))
    mixture_estimate(x, P, w, rows, cols, x_out, P_out)
    return x_out, P_out


@pytest.mark.parametrize("N", [1, 2, 3, 6])
def test_kernel_is_the_einsum_form_to_the_bit(N):
    rng = np.random.default_rng(N)
    for _ in range(200):
        x, P, w, rows, cols = _case(rng, N, int(rng.integers(6, 20)))
        x_ref, P_ref = weighted_estimate(x[rows[:, None], cols], P[rows[:, None, None], cols[:, None], cols], w[rows])
        x_k, P_k = _kernel(x, P, w, rows, cols)
        assert x_k.tobytes() == x_ref.tobytes()
        assert P_k.tobytes() == P_ref.tobytes()


def test_kernel_is_the_mixture_of_its_filters():
    """x̂ = Σ p_i x̂_i and P = Σ p_i (P_i + x̂_i x̂_iᵀ) − x̂ x̂ᵀ (the second moment, a different
    expression of the same mixture), on states of one scale so the subtraction stays accurate."""
    rng = np.random.default_rng(7)
    for _ in range(100):
        N, n = 4, 9
        x = rng.standard_normal((N, n))
        A = rng.standard_normal((N, n, n))
        P = np.ascontiguousarray(A @ A.transpose(0, 2, 1))
        w = rng.dirichlet(np.ones(N))
        rows, cols = np.arange(N), np.array([0, 2, 3, 5, 8])
        x_k, P_k = _kernel(x, P, w, rows, cols)
        xs, Ps = x[:, cols], P[:, cols][:, :, cols]
        mean = np.average(xs, axis=0, weights=w)
        second = sum(wi * (Pi + np.outer(xi, xi)) for wi, xi, Pi in zip(w, xs, Ps)) - np.outer(mean, mean)
        np.testing.assert_allclose(x_k, mean, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(P_k, second, rtol=1e-10, atol=1e-12)
        assert np.array_equal(P_k, P_k.T)


def test_only_the_named_filters_and_states_count():
    rng = np.random.default_rng(3)
    x, P, w, _, _ = _case(rng, 3, 8)
    w = np.array([0.25, 0.0, 0.75])
    rows, cols = np.array([0, 2]), np.array([1, 4])
    noisy_x, noisy_P = x.copy(), P.copy()
    noisy_x[1], noisy_P[1] = np.nan, np.nan  # a filter left out is never read
    noisy_x[:, 0], noisy_P[:, 0, :] = np.nan, np.nan  # nor a state left out
    assert all(a.tobytes() == b.tobytes() for a, b in zip(_kernel(noisy_x, noisy_P, w, rows, cols),
                                                           _kernel(x, P, w, rows, cols)))
    x_k, _ = _kernel(x, P, w, rows, cols)
    np.testing.assert_allclose(x_k, 0.25 * x[0, cols] + 0.75 * x[2, cols], rtol=1e-15)


def test_arguments_of_another_layout_are_refused():
    rng = np.random.default_rng(1)
    x, P, w, rows, cols = _case(rng, 3, 6)
    with pytest.raises(TypeError):
        mixture_estimate(np.asfortranarray(x), P, w, rows, cols, np.empty(cols.size), np.empty((cols.size,) * 2))

"""Compiled kernel: one measurement's terms of the chi-square network's batch sums.

Lubey & Ely 2022 eq. 6 sums G_k,i = Σ_j G_k,i,j over the measurements j of batch k, where
G_k,i,j = z̄ᵀS⁻¹z̄ if filter i processed measurement j and, by the §3.2 substitution, n_j (the
mean of a χ²_{n_j} variable) if it did not. :class:`fsw.gating.chi2.Chi2Network` keeps four
running sums per filter — the chi-squares and dimensions of the measurements it processed, and of
those it did not — and forms G_k from them when the batch closes (the substitution is a
parameter; the two-sided network reads the same sums). Added one measurement at a time, in
arrival order, each sum is the same sequence of float64 additions as in Python.
"""

from __future__ import annotations

from numba import njit

from fsw.kernels import configure_cache_dir, stamp_with_all_kernel_sources

configure_cache_dir()
stamp_with_all_kernel_sources()


@njit("void(float64[::1], boolean[::1], float64, float64[:, ::1])", cache=True)
def chi2_batch_sums(chi2, processed, n, sums):
    """Add measurement j's chi-squares ``chi2`` (N,) and dimension ``n`` to ``sums`` (4, N):
    rows 0 and 1 where ``processed``, rows 2 and 3 where not."""
    for i in range(chi2.shape[0]):
        if processed[i]:
            sums[0, i] += chi2[i]
            sums[1, i] += n
        else:
            sums[2, i] += chi2[i]
            sums[3, i] += n

"""Batched Kalman measurement update shared by the linear and the extended filter banks.

All arrays carry a leading filter axis N so one call updates every filter of a bank:
x (N, n), P (N, n, n), H (N, m, n), R (N, m, m), residual (N, m).

The covariance update is the Joseph form P⁺ = (I − KH) P̄ (I − KH)ᵀ + K R Kᵀ, evaluated as a
congruence of the joint prior covariance of state and predicted measurement::

    M = [[P̄,  P̄Hᵀ], [HP̄, S]]  (S = HP̄Hᵀ + R),   P⁺ = [I, −K] M [I, −K]ᵀ,

which expands to exactly the Joseph form. M = [I; H] P̄ [I; H]ᵀ + diag(0, R) is positive
semi-definite by construction, so P⁺ is too for ANY gain K, and an error δK in the gain only
adds δK S δKᵀ (second order) — the properties that keep P SPD over tens of thousands of
updates. Writing it this way also gives P̄Hᵀ and S as blocks of M, and costs two batched
products instead of four. A filter that does not process a measurement gets K = 0, which
leaves x̄ and P̄ unchanged through the same arithmetic.

The rounding of that congruence is relative to ‖M‖ ≥ ‖P̄‖, though. Where a measurement is
many orders of magnitude stronger than the prior, P⁺ is that much smaller than P̄ and the
rounding swamps it; :func:`update_explicit`, the linear bank's update, forms the Joseph
products so that their rounding is relative to P⁺'s own terms (numbers there).

The EKF bank runs :func:`update`'s arithmetic compiled (:mod:`fsw.kernels.joseph_update`, for
measurements of one or two components); :func:`update` is its reference and serves larger m.
"""

from __future__ import annotations

import numpy as np


def augmented_joint(x: np.ndarray, P: np.ndarray, H: np.ndarray, R: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """The augmented joint prior M̃ = [[P̄, −x̄, P̄Hᵀ], [HP̄, z̄, S]], shape (N, n+m, n+1+m).

    The state column rides along through the update so that the same products that give
    the Joseph covariance also give the updated state (see :func:`update`).
    """
    N, n, _ = P.shape
    m = H.shape[1]
    B = np.empty((N, n + m, n))
    B[:, :n, :] = np.eye(n)
    B[:, n:, :] = H
    M = B @ P @ B.transpose(0, 2, 1)
    Mt = np.empty((N, n + m, n + 1 + m))
    Mt[:, :, :n] = M[:, :, :n]
    Mt[:, :, n + 1 :] = M[:, :, n:]
    Mt[:, n:, n + 1 :] += R
    Mt[:, :n, n] = -x
    Mt[:, n:, n] = residual
    return Mt


_COFACTOR_SIGNS = np.array([[1.0, -1.0], [-1.0, 1.0]])


def inverse_spd(S: np.ndarray) -> np.ndarray:
    """Inverse of a stack of small symmetric positive definite matrices (N, m, m); closed form
    for 1×1 and 2×2 (range/Doppler and optical), LAPACK beyond."""
    m = S.shape[-1]
    if m == 1:
        return 1.0 / S
    if m == 2:
        out = S[:, ::-1, ::-1] * _COFACTOR_SIGNS  # adjugate of [[a, b], [c, d]] is [[d, -b], [-c, a]]
        out /= np.vecdot(S[:, 0, :], out[:, :, 0])[:, None, None]  # det = first row · adj column
        return out
    return np.linalg.inv(S)


def chi_square(residual: np.ndarray, S_inv: np.ndarray) -> np.ndarray:
    """z̄ᵀ S⁻¹ z̄ per filter (Lubey & Ely 2022 eq. 6, G_k,i,j)."""
    return np.vecdot(residual, np.matvec(S_inv, residual))


def _gain_rows(Mt: np.ndarray, n: int) -> np.ndarray:
    """G = S⁻¹ M̃_bottom (N, m, n+1+m); Cramer's rule for m ≤ 2 (a LAPACK call costs more
    than the whole 2×2 inverse)."""
    m = Mt.shape[1] - n
    S = Mt[:, n:, n + 1 :]
    if m == 2:
        adj = S[:, ::-1, ::-1] * _COFACTOR_SIGNS
        adj /= np.vecdot(S[:, 0, :], adj[:, :, 0])[:, None, None]  # det = first row · adj column
        return adj @ Mt[:, n:, :]
    if m == 1:
        return Mt[:, n:, :] / S
    return np.linalg.solve(S, Mt[:, n:, :])


def _joseph(Mt: np.ndarray, G: np.ndarray, n: int) -> np.ndarray:
    """[P⁺ | −x⁺] (N, n, n+1) from the augmented joint prior and G (see :func:`update`)."""
    # Whole (n+m)-row blocks keep every elementwise operand contiguous (a row slice of a
    # stack is not, and costs ~4x more per element); the m extra rows are dropped at the end.
    LM = np.matmul(Mt[:, :, n + 1 :], G)
    np.subtract(Mt, LM, out=LM)
    PX = np.matmul(LM[:, :, n + 1 :], G[:, :, : n + 1])
    np.subtract(LM[:, :, : n + 1], PX, out=PX)
    return PX[:, :n, :]


def _gated_gain(
    Mt: np.ndarray, n: int, processes: np.ndarray | None, gate: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """G = S⁻¹ M̃_bottom, z̄, the chi-square z̄ᵀS⁻¹z̄ and which filters update (``processes``
    and, with ``gate``, chi-square editing); G is zeroed for the filters that do not."""
    G = _gain_rows(Mt, n)
    residual = Mt[:, n:, n]
    chi2 = np.vecdot(residual, G[:, :, n])
    does = processes
    if gate is not None:
        does = chi2 <= gate if processes is None else processes & (chi2 <= gate)
    if does is not None:
        G *= does[:, None, None]
    return G, residual, chi2, does


def update(
    Mt: np.ndarray, n: int, processes: np.ndarray | None = None, gate: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """One batched measurement update of N filters with n states from their augmented joint prior.

    ``Mt`` is [[P̄, −x̄, P̄Hᵀ], [HP̄, z̄, S]] (N, n+m, n+1+m), see :func:`augmented_joint`.
    ``processes`` (N,) says which filters update with this measurement (None: all);
    ``gate`` (N,) is the measurement-editing threshold on the chi-square (None: no editing).

    G = S⁻¹ M̃_bottom = [Kᵀ, S⁻¹z̄, I] gives the gain and the chi-square at once. With
    L = [I, −K]:  L M̃ = M̃_top − P̄Hᵀ G = [L M_left, −(x̄ + K z̄), L M_right], and the Joseph
    covariance is (L M) Lᵀ = (L M)_left − (L M)_right Kᵀ — the products of the congruence with
    L's identity block done exactly. (L M)_right = P̄Hᵀ − K S vanishes in exact arithmetic, so
    subtracting (L M)_right G from the state column as well changes it by rounding only, and
    [P⁺ | −x⁺] comes out of one subtraction.

    Returns (PX⁺, z̄, S, chi2, processed) where PX⁺ = [P⁺ | −x⁺] (N, n, n+1), P⁺ not
    symmetrised (see :func:`symmetrise`); z̄ and S are views into ``Mt``; processed is None
    when every filter processed. Filters that do not process keep x̄ and P̄ (zero gain) but
    still get their z̄, S and chi-square, which the gating networks need.
    """
    G, residual, chi2, does = _gated_gain(Mt, n, processes, gate)
    return _joseph(Mt, G, n), residual, Mt[:, n:, n + 1 :], chi2, does


def joseph_operands(H: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The constant operands of :func:`update_explicit` for H (N, m, n) and R (N, m, m).

    Returns (HI, E, W): HI = ½[−H, 0, I] (N, m, n+1+m); E = ½[I, 0, 0] (n, n+1+m), shared by
    all filters; W (N, n+1+m, n+1+m), zero but for its bottom-right block 2R.
    :func:`update_explicit` writes W's first n rows and its state column on every call (W is
    its workspace) and only reads the rest.
    """
    N, m, n = H.shape
    HI = np.zeros((N, m, n + 1 + m))
    HI[:, :, :n] = -0.5 * H
    HI[:, :, n + 1 :] = 0.5 * np.eye(m)
    E = np.zeros((n, n + 1 + m))
    E[:, :n] = 0.5 * np.eye(n)
    W = np.zeros((N, n + 1 + m, n + 1 + m))
    W[:, n + 1 :, n + 1 :] = 2.0 * R
    return HI, E, W


def update_explicit(
    Mt: np.ndarray, n: int, operands: tuple[np.ndarray, np.ndarray, np.ndarray], z: np.ndarray,
    processes: np.ndarray | None = None, gate: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """:func:`update` with the Joseph form evaluated explicitly, which stays accurate for
    measurements far stronger than the prior (R ≪ HP̄Hᵀ). The linear bank's update.

    Same arguments and results as :func:`update`, plus ``operands`` from
    :func:`joseph_operands` and the measurement z, (m,) or (N, m). PX⁺ is a view into a fresh
    array and its P⁺ is exactly symmetric.

    :func:`update` forms P⁺ = (L M)_left − (L M)_right Kᵀ, a difference of terms of size ‖P̄‖,
    so P⁺ carries rounding of size eps·‖P̄‖, which swamps it where the measurement has shrunk
    P̄ by R/HP̄Hᵀ. Linear bank SPD test, first update (P̄ ≈ diag(1e6, 1e4, 1e2), R = 1e-8 I₂),
    against an exact rational evaluation of the same update: P⁺ off by 1.3e-2 of
    √(P⁺ᵢᵢP⁺ⱼⱼ); fed to the second update, P⁺ then came out off by 60 (generic OpenBLAS
    kernels) to 900 (Haswell kernels) times √(P⁺ᵢᵢP⁺ⱼⱼ), with a negative diagonal and an
    asymmetry of 1.05·max|P⁺|.

    Here P⁺ = X W̃ Xᵀ with X = [I − KH, 0, K] and W̃ = [[P̄, −x̄, 0], [0, 0, 0], [0, −z, R]]:
    a congruence of the PSD block diagonal diag(P̄, R), so PSD up to its own rounding for any
    X. Where a measurement is strong, I − KH is small (of order R S⁻¹) and scales P̄ down
    before anything is summed: each product's rounding is relative to |I − KH| |P̄| |I − KH|ᵀ
    and |K| R |K|ᵀ, not to ‖P̄‖. X's left block I − KH carries an absolute rounding δ of
    eps; as (I − KH)P̄ = P⁺ for the optimal gain, δ moves P⁺ by δP⁺ + P⁺δᵀ + δP̄δᵀ, relative
    to P⁺ itself apart from the eps²·‖P̄‖ of the last term. Same test and reference:
    1.7e-16 at the first update; 1.1e-4 (Haswell) and 2.1e-4 (generic) at the second, whose
    P̄ is nearly singular (eigenvalues 11 orders of magnitude apart); below 6e-16 from the
    third on. The first product also gives the state: X W̃ has −(I − KH)x̄ − Kz = −x⁺ in its
    state column, which then meets X's zero column.

    X is formed halved and W̃ doubled (both exact), so the second product is ½P⁺, and
    P⁺ = ½P⁺ + (½P⁺)ᵀ comes out symmetric to the bit in the addition that a symmetrisation
    would cost anyway. Cost: two products of n × (n+1+m) by (n+1+m) per filter where
    :func:`update` needs two of inner width m — the linear bank's benchmark step (6 filters,
    15 states, 2 measurements) went from 20.6 to 29 µs.
    """
    HI, E, W = operands
    # a zero gain makes X = ½[I, 0, 0] below, which gives back x̄ and P̄
    G, residual, chi2, does = _gated_gain(Mt, n, processes, gate)
    X = np.matmul(G[:, :, :n].transpose(0, 2, 1), HI)  # K · ½[−H, 0, I]
    np.add(X, E, out=X)
    np.multiply(Mt[:, :n, : n + 1], 2.0, out=W[:, :n, : n + 1])
    W[:, n + 1 :, n] = -2.0 * np.asarray(z)
    Y = X @ W  # [(I − KH)P̄, −x⁺, KR]
    half_P = Y @ X.transpose(0, 2, 1)
    np.add(half_P, half_P.transpose(0, 2, 1), out=Y[:, :, :n])
    return Y[:, :, : n + 1], residual, Mt[:, n:, n + 1 :], chi2, does


def symmetrise(P: np.ndarray) -> np.ndarray:
    """(P + Pᵀ)/2 over the last two axes: removes the rounding asymmetry the products leave."""
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def is_spd(P: np.ndarray, rtol: float = 1e-10) -> bool:
    """P (n, n) symmetric (to ``rtol`` of its diagonal scale) and positive definite.

    ``rtol`` 1e-10 (~500 ulp): right after an update P carries the rounding asymmetry of one
    Joseph product, whose size depends on the BLAS kernel's summation order (up to 2.7e-12 of
    the correlation scale measured with OpenBLAS's Haswell kernels); a real defect shows as an
    asymmetry of order 1 or a failed factorisation.

    Checked on the correlation matrix D^-½ P D^-½: states with very different units (km and
    km/s²) would otherwise make a plain Cholesky test meaningless. Zero-variance rows (blocks
    a filter does not estimate) must be all-zero and are skipped.
    """
    d = np.diag(P)
    live = d != 0.0
    if np.any(d < 0.0) or np.any(P[~live]) or np.any(P[:, ~live]):
        return False
    Pl = P[np.ix_(live, live)]
    s = 1.0 / np.sqrt(d[live])
    C = Pl * s[:, None] * s[None, :]
    if not np.all(np.isfinite(C)) or np.max(np.abs(C - C.T), initial=0.0) > rtol:
        return False
    try:
        np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        return False
    return True

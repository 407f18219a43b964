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
rounding swamps it; the linear bank's update (:mod:`fsw.kernels.linear_step`) forms the Joseph
products X P̄ Xᵀ with X = I − KH so that their rounding is relative to P⁺'s own terms.

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

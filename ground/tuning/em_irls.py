"""EM with IRLS for the two-level (hierarchical) gating network on post-processed data
(Chaer et al. 1998 §IV, eqs. 17–23; Jordan & Jacobs 1994).

The data are the per-filter residual log-densities ln f(z_k | α_{j|i}) of a bank processed once
(eq. 7) and the gating input φ_k (the FSW's gates use φ = [1]; any (N, d) input works). The
parameters Θ are the softmax weight vectors a_i of the top-level gate and a_{j|i} of each bank's
gate, g_{i,k} = softmax_i(a_iᵀ φ_k), g_{j|i,k} = softmax_j(a_{j|i}ᵀ φ_k). Each iteration:

* E step — the joint posteriors h_{ij,k} (eq. 18), h_{i,k} = Σ_j h_{ij,k}, h_{j|i,k} = h_{ij,k} / h_{i,k};
* M step — the top-level gate maximises Σ_k Σ_l h_{l,k} ln g_{l,k} (eq. 22) and bank i's gate
  Σ_k h_{i,k} Σ_m h_{m|i,k} ln g_{m|i,k} (eq. 23), each a (weighted) multinomial-logit maximum
  likelihood problem solved by IRLS: Newton steps Δ = (Φᵀ W Φ)⁻¹ Φᵀ (h − g) in the block form of
  the softmax, W the weighted softmax covariance, with step halving so the M objective never drops;

until the L1 change of Θ is below ε. The incomplete log-likelihood (eq. 17) is recorded each
iteration; EM guarantees it never decreases, and :func:`run_em` raises if it does.

The last cell of every gate is pinned at a = 0 (softmax is invariant to a common shift), so the
fixed point is unique where the likelihood is strictly concave in the free cells.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _log_softmax(u: np.ndarray) -> np.ndarray:
    m = np.max(u, axis=-1, keepdims=True)
    return u - m - np.log(np.sum(np.exp(u - m), axis=-1, keepdims=True))


def _logsumexp(x: np.ndarray, axis: int) -> np.ndarray:
    m = np.max(x, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    return np.squeeze(m, axis=axis) + np.log(np.sum(np.exp(x - m), axis=axis))


def gate_log_weights(A: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """(N, C) ln g of a softmax gate with cells A (C, d) on inputs φ (N, d) (Chaer et al. 1998 eqs. 3–5)."""
    return _log_softmax(phi @ A.T)


def m_objective(A: np.ndarray, phi: np.ndarray, h: np.ndarray, w: np.ndarray) -> float:
    """Σ_k w_k Σ_c h_{c,k} ln g_{c,k}: eq. 22 (w = 1) and eq. 23 (w = h_i)."""
    return float(np.sum(w[:, None] * h * gate_log_weights(A, phi)))


def irls(A: np.ndarray, phi: np.ndarray, h: np.ndarray, w: np.ndarray, *, steps: int = 50,
         tol: float = 1e-10, ridge: float = 1e-9) -> np.ndarray:
    """Maximise :func:`m_objective` over the free cells (all but the last) by IRLS / Newton with
    step halving. ``ridge`` only conditions the Newton matrix (a target that puts all of its
    posterior on one cell has its optimum at infinity; the steps then grow without bound)."""
    A = np.array(A, dtype=float)
    C, d = A.shape
    if C < 2:
        return A
    f0 = m_objective(A, phi, h, w)
    for _ in range(steps):
        g = np.exp(gate_log_weights(A, phi))  # (N, C)
        r = (w[:, None] * (h - g))[:, :-1]  # (N, C-1)
        grad = (r.T @ phi).reshape(-1)  # cell-major: (C-1) blocks of d
        gf = g[:, :-1]
        # −Hessian: Σ_k w_k (diag(g) − g gᵀ) ⊗ φ φᵀ over the free cells
        cov = np.einsum("k,kc,ce->kce", w, gf, np.eye(C - 1)) - np.einsum("k,kc,ke->kce", w, gf, gf)
        H = np.einsum("kce,ka,kb->cae b".replace(" ", ""), cov, phi, phi).reshape((C - 1) * d, (C - 1) * d)
        H += ridge * np.eye(H.shape[0])
        try:
            step = np.linalg.solve(H, grad)
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(H, grad, rcond=None)[0]
        t = 1.0
        while True:
            trial = A.copy()
            trial[:-1] += t * step.reshape(C - 1, d)
            f1 = m_objective(trial, phi, h, w)
            if f1 >= f0 or t < 1e-8:
                break
            t *= 0.5
        if f1 < f0:
            break
        moved = float(np.max(np.abs(trial - A)))
        A, gain, f0 = trial, f1 - f0, f1
        if moved < tol or gain < tol * max(1.0, abs(f0)):
            break
    return A


@dataclass
class Hierarchy:
    """Θ: top cells (K, d) and one (L_i, d) cell array per bank."""

    top: np.ndarray
    banks: list[np.ndarray]

    def vector(self) -> np.ndarray:
        return np.concatenate([self.top.ravel(), *[b.ravel() for b in self.banks]])

    def copy(self) -> "Hierarchy":
        return Hierarchy(self.top.copy(), [b.copy() for b in self.banks])


def log_joint(theta: Hierarchy, log_f: list[np.ndarray], phi: np.ndarray) -> list[np.ndarray]:
    """Per bank i, (N, L_i) ln g_{i,k} + ln g_{j|i,k} + ln f(z_k | α_{j|i})."""
    lg_top = gate_log_weights(theta.top, phi)
    return [lg_top[:, i:i + 1] + gate_log_weights(theta.banks[i], phi) + lf for i, lf in enumerate(log_f)]


def log_likelihood(theta: Hierarchy, log_f: list[np.ndarray], phi: np.ndarray) -> float:
    """The incomplete log-likelihood of eq. 17."""
    lj = np.concatenate(log_joint(theta, log_f, phi), axis=1)
    return float(np.sum(_logsumexp(lj, axis=1)))


def posteriors(theta: Hierarchy, log_f: list[np.ndarray], phi: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """E step: h_{i,k} (N, K) and h_{j|i,k} per bank (N, L_i) (eqs. 9, 10, 18)."""
    lj = log_joint(theta, log_f, phi)
    total = _logsumexp(np.concatenate(lj, axis=1), axis=1)
    lbank = np.stack([_logsumexp(x, axis=1) for x in lj], axis=1)  # ln Σ_j joint
    h_top = np.exp(lbank - total[:, None])
    h_in = [np.exp(x - lbank[:, i:i + 1]) for i, x in enumerate(lj)]
    return h_top, h_in


@dataclass
class EmResult:
    theta: Hierarchy
    log_likelihood: list[float] = field(default_factory=list)  # eq. 17 at Θ_0, Θ_1, …
    changes: list[float] = field(default_factory=list)  # L1 change of Θ per iteration
    converged: bool = False

    @property
    def iterations(self) -> int:
        return len(self.changes)


class LikelihoodDecreased(RuntimeError):
    """EM's incomplete likelihood fell between two iterations (it must not: Dempster et al. 1977)."""


def initial(n_banks: int, bank_sizes: list[int], d: int) -> Hierarchy:
    """Equal weights everywhere (all cells zero)."""
    return Hierarchy(np.zeros((n_banks, d)), [np.zeros((L, d)) for L in bank_sizes])


def _check(log_f: list[np.ndarray], phi: np.ndarray | None) -> tuple[list[np.ndarray], np.ndarray]:
    if not log_f:
        raise ValueError("need at least one bank")
    log_f = [np.atleast_2d(np.asarray(x, dtype=float)) for x in log_f]
    N = log_f[0].shape[0]
    if N < 1 or any(x.ndim != 2 or x.shape[0] != N or x.shape[1] < 1 for x in log_f):
        raise ValueError("every bank's log-densities must be (N, L_i) with the same N >= 1")
    if not all(np.all(np.isfinite(x)) for x in log_f):
        raise ValueError("log-densities must be finite")
    phi = np.ones((N, 1)) if phi is None else np.asarray(phi, dtype=float)
    if phi.ndim != 2 or phi.shape[0] != N or not np.all(np.isfinite(phi)):
        raise ValueError(f"the gate input must be a finite (N, d) array with N = {N}")
    return log_f, phi


def _weight_vector(theta: Hierarchy, phi: np.ndarray) -> np.ndarray:
    top, banks = weights(theta, phi)
    return np.concatenate([top.mean(axis=0), *[b.mean(axis=0) for b in banks]])


def run_em(log_f: list[np.ndarray], phi: np.ndarray | None = None, *, theta0: Hierarchy | None = None,
           epsilon: float = 1e-6, max_iterations: int = 500, irls_steps: int = 50,
           change_of: str = "parameters") -> EmResult:
    """Chaer et al. 1998 §IV algorithm summary, steps 1–4: E step, IRLS for the top gate (eq. 22),
    weighted IRLS for each bank's gate (eq. 23), until the L1 change of Θ is below ε.

    ``change_of = "weights"`` measures the change on the gate weights (averaged over the set)
    instead: where a weight tends to zero its cell's parameters grow without bound (ever more
    slowly), so the parameters' change never falls below ε although the weights have settled."""
    if change_of not in ("parameters", "weights"):
        raise ValueError(f"change_of must be 'parameters' or 'weights', got {change_of!r}")
    log_f, phi = _check(log_f, phi)
    theta = (theta0 or initial(len(log_f), [x.shape[1] for x in log_f], phi.shape[1])).copy()
    out = EmResult(theta, [log_likelihood(theta, log_f, phi)])
    ones = np.ones(phi.shape[0])
    for _ in range(max_iterations):
        h_top, h_in = posteriors(theta, log_f, phi)
        new = Hierarchy(irls(theta.top, phi, h_top, ones, steps=irls_steps),
                        [irls(theta.banks[i], phi, h_in[i], h_top[:, i], steps=irls_steps) for i in range(len(log_f))])
        if change_of == "parameters":
            change = float(np.sum(np.abs(new.vector() - theta.vector())))
        else:
            change = float(np.sum(np.abs(_weight_vector(new, phi) - _weight_vector(theta, phi))))
        ll = log_likelihood(new, log_f, phi)
        if ll < out.log_likelihood[-1] - 1e-9 * max(1.0, abs(out.log_likelihood[-1])):
            raise LikelihoodDecreased(f"eq. 17 fell from {out.log_likelihood[-1]:.12g} to {ll:.12g}")
        theta = new
        out.theta, out.converged = theta, change < epsilon
        out.log_likelihood.append(ll)
        out.changes.append(change)
        if out.converged:
            break
    return out


def weights(theta: Hierarchy, phi: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """g_{i,k} (N, K) and g_{j|i,k} per bank (N, L_i) under Θ."""
    return np.exp(gate_log_weights(theta.top, phi)), [np.exp(gate_log_weights(b, phi)) for b in theta.banks]

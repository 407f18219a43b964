"""The per-measurement output of the filter bank: what every gating network consumes.

Lubey & Ely 2022 §3.1 (eq. 5) needs, for every filter i and every measurement j, the predicted residual
z̄_ij = y_j − h_ij(t_j, x̄_ij) and its innovation covariance S_ij = R_ij + H̃_ij P̄_ij H̃_ijᵀ, whether
or not filter i processes measurement j (§3.2 substitutes G = n_j for unprocessed ones, but
Magill and the mixture-of-experts networks use all residuals). The bank therefore emits one
``BankRecord`` per measurement holding these quantities for all N filters at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.interface.frozen import fast_init


@fast_init
@dataclass(frozen=True, slots=True)
class BankRecord:
    """Residual statistics of all N filters of a bank for one measurement j.

    Attributes
    ----------
    t : float
        Measurement time tag, TDB seconds past J2000 (as the onboard clock reports it).
    seq : int
        Measurement sequence number (ICD ``Measurement.seq``).
    kind : str
        Measurement kind (ICD ``MeasurementKind`` value, e.g. ``"range"``).
    filters : tuple[str, ...]
        Filter names, in bank order; all arrays below are indexed the same way.
    residual : ndarray (N, n)
        Predicted (pre-update) residual z̄_ij = y_j − h_ij(x̄_ij) in measurement units.
    S : ndarray (N, n, n)
        Innovation covariance S_ij = R_ij + H̃_ij P̄_ij H̃_ijᵀ.
    chi2 : ndarray (N,)
        z̄_ijᵀ S_ij⁻¹ z̄_ij (Lubey & Ely 2022 eq. 6, G_k,i,j before the §3.2 substitution).
    processed : ndarray (N,) of bool
        True where filter i processed (updated its state with) measurement j.
    active : ndarray (N,) of bool
        False where filter i is disabled (telecommand); gating networks leave a disabled
        filter's weight at zero and renormalise over the active ones.
    """

    t: float
    seq: int
    kind: str
    filters: tuple[str, ...]
    residual: np.ndarray
    S: np.ndarray
    chi2: np.ndarray
    processed: np.ndarray
    active: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Measurement dimension n_j (Lubey & Ely 2022 §3.2: the mean of a χ²_{n_j} variable)."""
        return self.residual.shape[1]

    @property
    def size(self) -> int:
        """Number of filters N."""
        return len(self.filters)

    def active_mask(self) -> np.ndarray:
        if self.active is None:
            return np.ones(self.size, dtype=bool)
        return np.asarray(self.active, dtype=bool)

    def log_likelihood(self) -> np.ndarray:
        """ln N(z̄; 0, S) per filter: the Gaussian residual density behind Magill (Lubey & Ely 2022 eq. 2,
        Chaer et al. 1997 eq. 7)."""
        n = self.n
        sign, logdet = np.linalg.slogdet(self.S)
        return -0.5 * (self.chi2 + logdet + n * np.log(2.0 * np.pi))

"""One random draw of the truth's uncertain forces: SRP scale factor, ACS thrusting, TCM errors.

* SRP scale factor (Lubey & Ely 2022 Table 1): s_k = 1 + b + g_k on batch k, with b ~ N(0, sigma_b^2)
  and g an exponentially correlated random variable (Chaer et al. 1998 eqs. 25-26):
  g_0 ~ N(0, sigma^2), g_{k+1} = exp(-dt/tau) g_k + w_k, E[w_k^2] = sigma^2 (1 - exp(-2 dt/tau)).
* ACS thrusting (Lubey & Ely 2022 Table 1 and §4.4): thruster i in batch k has magnitude
  scale * nominal * (1 + sigma_bias_rel * beta_i + sigma_daily_rel * delta_ik), beta, delta
  ~ N(0, 1) independent (no correlation between batches). A large §4.4 dispersion can make a
  magnitude negative: the thrust then acts along minus the thruster direction.
  Each thruster direction carries a constant pointing error, N(0, sigma^2) on each of two
  transverse axes.
* TCM execution errors: N(0, (sigma_rel |dv|)^2) per axis.
* Non-gravitational acceleration (NGA, Chaer et al. 1998 §V): three independent ECRVs on the inertial
  axes, constant over batches of ``nga_batch_s`` from t0 and stepping by eq. 25 at each edge:
  x_0 = sigma w_0, x_{k+1} = m x_k + sigma sqrt(1 - m^2) w_{k+1}, m = exp(-T_b/tau), w ~ N(0, 1).
  The normals w are kept so that a level change (fault ``nga-level``) can continue the same
  random sequence with another steady-state sigma (:meth:`StochasticRealisation.with_nga_sigma`).

All draws come from the numpy Generator handed in, in a fixed order, so a seed fixes the run.
The NGA normals come from a second generator of their own, so switching the NGA on or off never
changes the other draws.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY
from sim.dynamics.config import ForceModelConfig


class DynamicsError(ValueError):
    """Bad input to the truth dynamics (span, times, state) or a query outside the trajectory."""


@dataclass(frozen=True)
class Maneuver:
    """A realised impulsive burn."""

    t_tdb: float
    dv_km_s: np.ndarray  # (3,) as executed (truth)
    dv_planned_km_s: np.ndarray  # (3,) as commanded


@dataclass(frozen=True)
class StochasticRealisation:
    """Piecewise-constant realised force parameters over [t0, t1]."""

    t0: float
    t1: float
    srp_edges: np.ndarray  # (nb+1,) batch edges, srp_edges[0] = t0, srp_edges[-1] = t1
    srp_scale: np.ndarray  # (nb,)
    acs_edges: np.ndarray  # (na+1,)
    acs_magnitudes: np.ndarray  # (n_thrusters, na) km/s^2
    acs_directions_body: np.ndarray  # (n_thrusters, 3) unit vectors, pointing errors included
    maneuvers: tuple[Maneuver, ...]
    nga_edges: np.ndarray | None = None  # (ng+1,) NGA batch edges; None: no NGA
    nga_accel: np.ndarray | None = None  # (ng, 3) ICRF km/s^2
    nga_normals: np.ndarray | None = None  # (ng, 3) the standard normals behind nga_accel
    nga_factor: float = 0.0  # m = exp(-T_b/tau) of the NGA batches

    @staticmethod
    def _edges(t0: float, t1: float, batch_s: float) -> np.ndarray:
        n = max(1, int(math.ceil((t1 - t0) / batch_s - 1e-9)))
        edges = t0 + batch_s * np.arange(n + 1, dtype=float)
        edges[-1] = t1
        return edges

    @classmethod
    def draw(cls, forces: ForceModelConfig, t0: float, t1: float, rng: np.random.Generator | None,
             nga_rng: np.random.Generator | None = None) -> "StochasticRealisation":
        """Draw a realisation over [t0, t1]; ``rng`` may be None only if no sigma is non-zero.

        ``nga_rng`` draws the NGA normals (3 per batch); it is needed only when
        ``forces.nga_sigma_km_s2`` > 0."""
        if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
            raise DynamicsError(f"realisation span must be finite with t1 > t0, got [{t0}, {t1}]")
        random_parts = (forces.srp_bias_sigma, forces.srp_gm_sigma, forces.acs_bias_sigma_rel,
                        forces.acs_daily_sigma_rel, forces.acs_direction_sigma_deg,
                        *(m.dv_sigma_rel for m in forces.maneuvers))
        if rng is None:
            if any(p > 0.0 for p in random_parts):
                raise DynamicsError("a numpy Generator is needed when any dispersion sigma is non-zero")
            rng = np.random.default_rng(0)  # every draw below is multiplied by zero

        srp_edges = cls._edges(t0, t1, forces.srp_batch_days * SECONDS_PER_DAY)
        nb = srp_edges.size - 1
        bias = forces.srp_bias_sigma * rng.standard_normal()
        phi = math.exp(-forces.srp_batch_days / forces.srp_tau_days)
        q = forces.srp_gm_sigma * math.sqrt(1.0 - phi * phi)
        w = rng.standard_normal(nb)
        gm = np.empty(nb)
        gm[0] = forces.srp_gm_sigma * w[0]
        for k in range(1, nb):
            gm[k] = phi * gm[k - 1] + q * w[k]
        srp_scale = 1.0 + bias + gm

        acs_edges = cls._edges(t0, t1, forces.acs_batch_days * SECONDS_PER_DAY)
        na = acs_edges.size - 1
        dirs: np.ndarray = np.array(forces.acs_directions_body, dtype=float)
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        nt = int(dirs.shape[0])
        beta = rng.standard_normal(nt)
        delta = rng.standard_normal((nt, na))
        nominal = forces.acs_scale * forces.acs_nominal_km_s2
        mags = nominal * (1.0 + forces.acs_bias_sigma_rel * beta[:, None] + forces.acs_daily_sigma_rel * delta)
        sig = math.radians(forces.acs_direction_sigma_deg)
        tilt = rng.standard_normal((nt, 2)) * sig
        for i in range(nt):
            e1 = np.cross(dirs[i], [1.0, 0.0, 0.0] if abs(dirs[i, 0]) < 0.9 else [0.0, 1.0, 0.0])
            e1 /= np.linalg.norm(e1)
            e2 = np.cross(dirs[i], e1)
            d = dirs[i] + tilt[i, 0] * e1 + tilt[i, 1] * e2
            dirs[i] = d / np.linalg.norm(d)

        mans = []
        for m in sorted(forces.maneuvers, key=lambda m: m.epoch_offset_days):
            planned = np.array(m.dv_km_s, dtype=float)
            err = rng.standard_normal(3) * m.dv_sigma_rel * np.linalg.norm(planned)
            mans.append(Maneuver(t0 + m.epoch_offset_days * SECONDS_PER_DAY, planned + err, planned))
        out = cls(float(t0), float(t1), srp_edges, srp_scale, acs_edges, mags, dirs, tuple(mans))
        if forces.nga_sigma_km_s2 > 0.0:
            if nga_rng is None:
                raise DynamicsError("a numpy Generator for the NGA is needed when nga_sigma_km_s2 > 0")
            edges = cls._edges(t0, t1, forces.nga_batch_s)
            normals = nga_rng.standard_normal((edges.size - 1, 3))
            factor = math.exp(-forces.nga_batch_s / (forces.nga_tau_days * SECONDS_PER_DAY))
            out = dataclasses.replace(out, nga_edges=edges, nga_normals=normals, nga_factor=factor)
            out = out.with_nga_sigma(np.full(edges.size - 1, forces.nga_sigma_km_s2))
        return out

    def with_nga_sigma(self, sigma: np.ndarray) -> "StochasticRealisation":
        """The same NGA normals run through eq. 25 with steady-state sigma[k] in force on batch k.

        Batch 0 starts in steady state, x_0 = sigma_0 w_0; then x_k = m x_{k-1} + sigma_k
        sqrt(1 - m^2) w_k (eq. 26 with the sigma of the batch being entered)."""
        if self.nga_normals is None:
            raise DynamicsError("this realisation has no NGA")
        sigma = np.asarray(sigma, dtype=float)
        if sigma.shape != (self.nga_normals.shape[0],) or not np.all(np.isfinite(sigma)) or np.any(sigma < 0):
            raise DynamicsError("NGA sigma must be one non-negative value per NGA batch")
        m = self.nga_factor
        drive = self.nga_normals * (sigma * math.sqrt(1.0 - m * m))[:, None]
        drive[0] = sigma[0] * self.nga_normals[0]
        # imported here: scipy.signal costs every process that loads a scenario ~0.25 s at start
        from scipy.signal import lfilter

        accel = lfilter([1.0], [1.0, -m], drive, axis=0)
        return dataclasses.replace(self, nga_accel=accel)

    @classmethod
    def nominal(cls, forces: ForceModelConfig, t0: float, t1: float) -> "StochasticRealisation":
        """The design values: scale 1, nominal thrust, no pointing or execution errors."""
        return cls.draw(forces.without_dispersions(), t0, t1, None)

    def _batch(self, edges: np.ndarray, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise DynamicsError("non-finite time")
        return np.clip(np.searchsorted(edges, t, side="right") - 1, 0, edges.size - 2)

    def srp_scale_at(self, t):
        """SRP scale factor at t (scalar or array)."""
        out = self.srp_scale[self._batch(self.srp_edges, t)]
        return float(out) if np.ndim(out) == 0 else out

    def acs_magnitudes_at(self, t) -> np.ndarray:
        """Per-thruster magnitudes [km/s^2]: (n_thrusters,) for scalar t, (N, n_thrusters) for arrays."""
        return self.acs_magnitudes[:, self._batch(self.acs_edges, t)].T

    def acs_body_vector_at(self, t) -> np.ndarray:
        """Net ACS acceleration in the cruise body frame [km/s^2]; (3,) or (N, 3)."""
        return self.acs_magnitudes_at(t) @ self.acs_directions_body

    def nga_at(self, t) -> np.ndarray:
        """Realised NGA [km/s^2], ICRF: (3,) for scalar t, (N, 3) for arrays (zeros without NGA)."""
        if self.nga_edges is None or self.nga_accel is None:  # edges and accelerations are set together
            t = np.asarray(t, dtype=float)
            return np.zeros(t.shape + (3,))
        return self.nga_accel[self._batch(self.nga_edges, t)]

    def discontinuities(self) -> np.ndarray:
        """Sorted interior epochs where the piecewise-constant forces or the velocity jump."""
        nga = self.nga_edges[1:-1] if self.nga_edges is not None else np.zeros(0)
        pts = np.concatenate([self.srp_edges[1:-1], self.acs_edges[1:-1], nga, [m.t_tdb for m in self.maneuvers]])
        pts = pts[(pts > self.t0) & (pts < self.t1)]
        return np.unique(pts)

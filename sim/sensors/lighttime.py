"""Newtonian light-time solution between an emitter and a receiver given as position functions.

A signal received at ``t_rx`` by a receiver at r_rx(t_rx) left the emitter at t_tx with

    |r_rx(t_rx) - r_tx(t_tx)| = c (t_rx - t_tx),

both positions in one inertial frame (navbank uses the solar-system barycentre, so the
acceleration of Mars around the Sun over the ~5–20 minute light time — ~0.3 km — is not lost).
Solved for the light time tau = t_rx - t_tx by fixed-point iteration
tau <- |r_rx(t_rx) - r_tx(t_rx - tau)| / c, a contraction with factor |v_tx| / c ~ 1e-4, so a
few iterations reach the float64 floor.

Precision: t_tdb ~ 6e8 s carries only ~1.2e-7 s of resolution, i.e. 36 m of light travel and
~1 mm of station motion along the line of sight. So the light time is returned as a
*difference* (not as t_tx), and when the emitter's velocity is given, its position at the
rounded emission time fl(t_rx - tau) is corrected by v * e with e = (t_rx - fl(t_rx - tau)) - tau,
the rounding error, which float arithmetic gives exactly (Sterbenz). The result is then good to
~1e-12 s, so 60 s Doppler counts differenced from it carry no visible quantisation noise.

Not modelled (by truth or the onboard models): Shapiro delay, troposphere, ionosphere,
station/antenna delays.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from fsw.astro.constants import C_KM_S

PositionFn = Callable[[np.ndarray], np.ndarray]
StateFn = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


class LightTimeError(ValueError):
    """The light-time iteration did not converge or the geometry is degenerate."""


def light_time(
    t_rx: np.ndarray,
    receiver_at_rx: np.ndarray,
    emitter: PositionFn,
    emitter_velocity: PositionFn | None = None,
    tol_s: float = 1e-11,
    max_iter: int = 12,
    emitter_state: StateFn | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Light time tau [s] and emitter position r_tx(t_rx - tau) [km] for each reception.

    ``t_rx`` (N,) TDB seconds; ``receiver_at_rx`` (N, 3) receiver positions at t_rx;
    ``emitter(t)`` maps (N,) times to (N, 3) positions in the same frame, and
    ``emitter_velocity(t)`` (optional) to velocities [km/s] for the sub-resolution correction.
    ``emitter_state(t)`` (optional, used instead of both inside the iteration) gives their
    (position, velocity) at once, for emitters whose two share most of their cost.
    """
    t_rx = np.asarray(t_rx, dtype=float)
    r_rx = np.asarray(receiver_at_rx, dtype=float)
    if r_rx.shape != t_rx.shape + (3,):
        raise LightTimeError(f"receiver positions {r_rx.shape} do not match {t_rx.shape} times")
    r_tx = emitter(t_rx)
    tau = np.linalg.norm(r_rx - r_tx, axis=-1) / C_KM_S
    for _ in range(max_iter):
        t_tx = t_rx - tau
        if emitter_state is not None:
            r_tx, v_tx = emitter_state(t_tx)
            r_tx = r_tx + v_tx * ((t_rx - t_tx) - tau)[:, None]
        else:
            r_tx = emitter(t_tx)
            if emitter_velocity is not None:
                r_tx = r_tx + emitter_velocity(t_tx) * ((t_rx - t_tx) - tau)[:, None]
        new = np.linalg.norm(r_rx - r_tx, axis=-1) / C_KM_S
        done = np.max(np.abs(new - tau), initial=0.0) <= tol_s
        tau = new
        if done:
            break
    else:
        raise LightTimeError(f"light time did not converge to {tol_s} s in {max_iter} iterations")
    if not np.all(np.isfinite(tau)) or np.any(tau <= 0.0):
        raise LightTimeError("degenerate light-time geometry (coincident or non-finite positions)")
    return tau, r_tx

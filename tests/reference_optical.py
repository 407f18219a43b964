"""The numpy camera model the compiled kernel (fsw.kernels.camera) replaced, kept as the independent
reference the kernel tests compare against."""

from __future__ import annotations

import numpy as np

from fsw.astro.constants import C_KM_S
from fsw.astro.frames import quat_to_matrix
from fsw.models.environment import MARS, Environment
from fsw.models.optical import GeometryError


def reference_optical(
    env: Environment,
    target: str,
    t: float,
    r: np.ndarray,
    v: np.ndarray,
    attitude_q: np.ndarray,
    focal_px: np.ndarray,
    principal_point: np.ndarray,
    light_time: np.ndarray,
    aberration: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predicted [sample, line] (N, 2) and its partials w.r.t. r and v (N, 2, 3) each.

    Camera parameters are per filter: ``focal_px`` (N,), ``principal_point`` (N, 2),
    ``light_time`` and ``aberration`` (N,) flags.
    """
    r_T, v_T = env.target_state(target, t)
    Vm = env.states_ssb(t)[1][MARS]
    g = r_T - r
    w = np.broadcast_to(v_T + Vm, g.shape)
    d = g.copy()
    for _ in range(4):
        tau = np.linalg.norm(d, axis=-1) / C_KM_S
        d = np.where(light_time[:, None], g - w * tau[:, None], g)
    dist = np.linalg.norm(d, axis=-1)
    if np.any(dist <= 0.0):
        raise GeometryError("spacecraft at the target centre")
    u = d / dist[:, None]
    # ∂d/∂r = −(I − w uᵀ/(c + u·w)) with light time, −I without
    lt = light_time.astype(float)[:, None, None]
    D_dg = np.eye(3) - lt * (w[:, :, None] * u[:, None, :]) / (C_KM_S + np.einsum("ni,ni->n", u, w))[:, None, None]
    dd_dr = -D_dg
    dd_dv = np.zeros_like(dd_dr)
    if np.any(aberration):
        ab = aberration.astype(float)
        proj = (np.eye(3) - u[:, :, None] * u[:, None, :]) / dist[:, None, None]
        app = u + (v + Vm) / C_KM_S
        d_eff = np.where(aberration[:, None], app, d)
        dd_dr = np.where(aberration[:, None, None], proj @ dd_dr, dd_dr)
        dd_dv = ab[:, None, None] * np.eye(3) / C_KM_S
        d = d_eff
    C = quat_to_matrix(np.asarray(attitude_q, dtype=float))
    Ct = C.T
    cam = d @ C  # rows: Cᵀ d
    z = cam[:, 2]
    if np.any(z <= 0.0):
        raise GeometryError(f"target {target!r} behind the camera")
    f = focal_px / z
    h = np.empty((r.shape[0], 2))
    h[:, 0] = principal_point[:, 0] + f * cam[:, 0]
    h[:, 1] = principal_point[:, 1] + f * cam[:, 1]
    J = np.zeros((r.shape[0], 2, 3))
    J[:, 0, 0] = f
    J[:, 1, 1] = f
    J[:, 0, 2] = -f * cam[:, 0] / z
    J[:, 1, 2] = -f * cam[:, 1] / z
    JC = J @ Ct
    return h, JC @ dd_dr, JC @ dd_dv

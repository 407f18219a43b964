"""Optical navigation: pinhole-camera sample/line of a target centre, with exact partials.

Camera frame: +z along the boresight, +x towards increasing sample, +y towards increasing
line; the attitude C (camera → ICRF) comes with the measurement (``attitude_q``, scalar first).
Pinhole model with focal length f in pixels (focal length / pixel pitch) and principal point
(c_s, c_l):

    sample = c_s + f x/z,   line = c_l + f y/z,   [x y z]ᵀ = Cᵀ d.

Line of sight d from the spacecraft to the target, light-time corrected in the SSB frame (as
the light travels): with g = r_T(t) − r(t) (Mars-centred) and w = v_T + V_M the target's SSB
velocity, d = r_T,B(t − τ) − r_sc,B(t) = g − w τ, τ = |d|/c (the target's acceleration over
τ moves it below a metre for the Mars system and ~1 km for an asteroid beacon 2 au away, 5e-9
rad there). Differentiating: dd = dg − w u·dd/c, so ∂d/∂g = I − w uᵀ/(c + u·w).

Optional first-order stellar aberration (off by default: the attitude comes from star trackers
that see the same aberration): d_app = d/|d| + (v + V_M)/c.

The clock phase (µs) shifts the image epoch by millimetres and is not modelled.
"""

from __future__ import annotations

import numpy as np

from fsw.astro.constants import C_KM_S
from fsw.astro.frames import quat_to_matrix
from fsw.kernels import on_first_call
from fsw.kernels.codes import AT_TARGET, BEHIND_CAMERA
from fsw.models.environment import MARS, Environment

pinhole_image = on_first_call(globals(), "pinhole_image", "fsw.kernels.camera")


class GeometryError(ValueError):
    """The target cannot be imaged by the model (behind the camera, zero line of sight)."""


def optical(
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
    ``light_time`` and ``aberration`` (N,) flags. The arithmetic is the compiled kernel
    :func:`fsw.kernels.camera.pinhole_image`.
    """
    r_T, v_T = env.target_state(target, t)
    Vm = env.states_ssb(t)[1][MARS]
    N = r.shape[0]
    h = np.empty((N, 2))
    Hr = np.empty((N, 2, 3))
    Hv = np.empty((N, 2, 3))
    code = pinhole_image(np.ascontiguousarray(r_T - r), np.ascontiguousarray(v, dtype=float),
                         np.ascontiguousarray(v_T + Vm, dtype=float), np.ascontiguousarray(Vm),
                         quat_to_matrix(np.asarray(attitude_q, dtype=float)), np.ascontiguousarray(focal_px, dtype=float),
                         np.ascontiguousarray(principal_point, dtype=float), np.ascontiguousarray(light_time, dtype=bool),
                         np.ascontiguousarray(aberration, dtype=bool), C_KM_S, h, Hr, Hv)
    if code == AT_TARGET:
        raise GeometryError("spacecraft at the target centre")
    if code == BEHIND_CAMERA:
        raise GeometryError(f"target {target!r} behind the camera")
    return h, Hr, Hv

"""Pinhole camera geometry: pointing frames, projection to pixels, small attitude errors.

Camera frame: +z along the boresight, +x towards increasing sample (right in the image),
+y towards increasing line (down in the image); right-handed. An attitude is the rotation
matrix C (camera -> ICRF, columns = camera axes in ICRF): v_icrf = C v_cam.

Pixel coordinates (sample, line): continuous, with pixel k (1-based) covering [k - 0.5, k + 0.5),
so the image spans [0.5, N + 0.5] and the centre of a 1024 x 1024 detector is (512.5, 512.5)
(the convention of the OpNav/ISIS camera models). The principal point is configurable.

Pinhole model:  sample = c_s + (f / p) x / z,  line = c_l + (f / p) y / z, with focal length f
and pixel pitch p (f / p in pixels; 500 mm / 12 um = 41,667 px, i.e. 24 urad per pixel).
"""

from __future__ import annotations

import numpy as np


class CameraError(ValueError):
    """Bad camera geometry input (zero or non-finite direction, target behind the camera)."""


def pointing_frame(boresight_icrf: np.ndarray, reference_icrf: np.ndarray | None = None) -> np.ndarray:
    """Camera -> ICRF matrices (N, 3, 3) with +z along ``boresight_icrf`` (N, 3).

    Roll: +y (line) is the part of ``reference_icrf`` (N, 3) across the boresight, so +x
    (sample) is along reference x boresight. The default reference is ICRF north: +x then
    points towards increasing right ascension and +y towards increasing declination.
    Where the reference is within 1e-6 rad of the boresight, ICRF x (then y) is used instead.
    """
    b = np.asarray(boresight_icrf, dtype=float)
    n = np.linalg.norm(b, axis=-1, keepdims=True)
    if not np.all(np.isfinite(b)) or np.any(n == 0.0):
        raise CameraError("boresight must be a finite non-zero vector")
    z = b / n
    if reference_icrf is None:
        ref = np.broadcast_to(np.array([0.0, 0.0, 1.0]), z.shape).copy()
    else:
        ref = np.broadcast_to(np.asarray(reference_icrf, dtype=float), z.shape).copy()
        if not np.all(np.isfinite(ref)) or np.any(np.linalg.norm(ref, axis=-1) == 0.0):
            raise CameraError("roll reference must be a finite non-zero vector")
        ref /= np.linalg.norm(ref, axis=-1, keepdims=True)
    for fallback in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        aligned = np.abs(np.einsum("ij,ij->i", ref.reshape(-1, 3), z.reshape(-1, 3))).reshape(z.shape[:-1]) > 1.0 - 5e-13
        ref[aligned] = fallback
    x = np.cross(ref, z)
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-1)


def small_rotation(theta: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of rotation vectors ``theta`` (N, 3) [rad] (Rodrigues)."""
    theta = np.asarray(theta, dtype=float)
    angle = np.linalg.norm(theta, axis=-1)
    k = np.where(angle[..., None] > 0.0, theta / np.where(angle > 0.0, angle, 1.0)[..., None], 0.0)
    K = np.zeros(theta.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -k[..., 2], k[..., 1]
    K[..., 1, 0], K[..., 1, 2] = k[..., 2], -k[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -k[..., 1], k[..., 0]
    s = np.sin(angle)[..., None, None]
    c = (1.0 - np.cos(angle))[..., None, None]
    return np.eye(3) + s * K + c * (K @ K)


def project(
    direction_icrf: np.ndarray,
    camera_to_icrf: np.ndarray,
    focal_px: float,
    principal_point: tuple[float, float],
) -> np.ndarray:
    """(N, 2) [sample, line] of directions (N, 3) seen by cameras with attitudes (N, 3, 3)."""
    d_cam = np.einsum("nji,nj->ni", camera_to_icrf, np.asarray(direction_icrf, dtype=float))
    z = d_cam[:, 2]
    if np.any(z <= 0.0):
        raise CameraError("a target is behind the camera")
    return np.column_stack(
        (principal_point[0] + focal_px * d_cam[:, 0] / z, principal_point[1] + focal_px * d_cam[:, 1] / z)
    )

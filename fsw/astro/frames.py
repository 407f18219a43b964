"""Rotations: elementary rotations, quaternions (scalar first), RA/Dec unit vectors.

Conventions
* ``rot_x/rot_y/rot_z(angle)`` are *frame* (passive) rotations, the R1/R2/R3 of the IERS
  Conventions: the coordinates of a fixed vector in a frame rotated by +angle about the axis.
  ``rot_z(-a)`` therefore turns a vector by +a.
* Quaternions are Hamilton, scalar first ``[w, x, y, z]``. ``quat_to_matrix(q)`` is the active
  rotation R(q): for an attitude quaternion body->inertial, ``v_inertial = R(q) @ v_body``.
"""

from __future__ import annotations

import math

import numpy as np


class FrameError(ValueError):
    """Bad input to a rotation function (wrong shape, zero-length quaternion or vector, NaN)."""


def _elementary(angle, i: int, j: int) -> np.ndarray:
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    m = np.zeros(a.shape + (3, 3))
    k = 3 - i - j
    m[..., k, k] = 1.0
    m[..., i, i] = c
    m[..., j, j] = c
    m[..., i, j] = s
    m[..., j, i] = -s
    return m


def rot_x(angle) -> np.ndarray:
    """R1(angle): frame rotation about x; vectorised over angle -> (..., 3, 3)."""
    return _elementary(angle, 1, 2)


def rot_y(angle) -> np.ndarray:
    """R2(angle): frame rotation about y."""
    return _elementary(angle, 2, 0)


def rot_z(angle) -> np.ndarray:
    """R3(angle): frame rotation about z."""
    return _elementary(angle, 0, 1)


def _as_quat(q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (4,):
        raise FrameError(f"quaternion must have 4 components (w, x, y, z), got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise FrameError("quaternion is not finite")
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise FrameError("zero quaternion")
    return q / n


def quat_to_matrix(q) -> np.ndarray:
    """Active rotation matrix of a unit quaternion [w, x, y, z] (normalised first); (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    if q.shape == (4,):
        return _quat_to_matrix_one(q)
    q = _as_quat(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1 - 2 * (y * y + z * z)
    m[..., 0, 1] = 2 * (x * y - w * z)
    m[..., 0, 2] = 2 * (x * z + w * y)
    m[..., 1, 0] = 2 * (x * y + w * z)
    m[..., 1, 1] = 1 - 2 * (x * x + z * z)
    m[..., 1, 2] = 2 * (y * z - w * x)
    m[..., 2, 0] = 2 * (x * z - w * y)
    m[..., 2, 1] = 2 * (y * z + w * x)
    m[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return m


def _quat_to_matrix_one(q: np.ndarray) -> np.ndarray:
    """:func:`quat_to_matrix` of one quaternion (an optical measurement's attitude) in Python
    floats: the same operations in the same order — the norm's squares summed left to right, as
    numpy's reduction of four numbers does — so the same bits, at a tenth of the cost."""
    w, x, y, z = q.tolist()
    if not (math.isfinite(w) and math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise FrameError("quaternion is not finite")
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if n < 1e-12:
        raise FrameError("zero quaternion")
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def matrix_to_quat(m) -> np.ndarray:
    """Unit quaternion [w, x, y, z] with w >= 0 of a proper rotation matrix (Shepperd's method)."""
    m = np.asarray(m, dtype=float)
    if m.shape != (3, 3):
        raise FrameError(f"expected a 3x3 matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)) or abs(np.linalg.det(m) - 1.0) > 1e-6:
        raise FrameError("not a proper rotation matrix")
    tr = np.trace(m)
    cand = np.array([tr, m[0, 0], m[1, 1], m[2, 2]])
    k = int(np.argmax(cand))
    if k == 0:
        w = 0.5 * np.sqrt(1.0 + tr)
        q = np.array([w, (m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w)])
    elif k == 1:
        x = 0.5 * np.sqrt(1.0 + 2 * m[0, 0] - tr)
        q = np.array([(m[2, 1] - m[1, 2]) / (4 * x), x, (m[0, 1] + m[1, 0]) / (4 * x), (m[0, 2] + m[2, 0]) / (4 * x)])
    elif k == 2:
        y = 0.5 * np.sqrt(1.0 + 2 * m[1, 1] - tr)
        q = np.array([(m[0, 2] - m[2, 0]) / (4 * y), (m[0, 1] + m[1, 0]) / (4 * y), y, (m[1, 2] + m[2, 1]) / (4 * y)])
    else:
        z = 0.5 * np.sqrt(1.0 + 2 * m[2, 2] - tr)
        q = np.array([(m[1, 0] - m[0, 1]) / (4 * z), (m[0, 2] + m[2, 0]) / (4 * z), (m[1, 2] + m[2, 1]) / (4 * z), z])
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


def quat_multiply(p, q) -> np.ndarray:
    """Hamilton product p * q (apply q first, then p, for active rotations)."""
    p, q = _as_quat(p), _as_quat(q)
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    ], axis=-1)


def quat_conjugate(q) -> np.ndarray:
    """Inverse rotation of a unit quaternion."""
    q = _as_quat(q)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def axis_angle_to_quat(axis, angle: float) -> np.ndarray:
    """Quaternion of an active rotation by ``angle`` [rad] about ``axis``."""
    a = unit(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * a])


def unit(v) -> np.ndarray:
    """v / |v| along the last axis; rejects zero or non-finite vectors."""
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise FrameError(f"expected 3-vectors, got shape {v.shape}")
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    if not np.all(np.isfinite(v)) or np.any(n == 0.0):
        raise FrameError("zero-length or non-finite vector")
    return v / n


def radec_to_unit(ra_rad, dec_rad) -> np.ndarray:
    """Unit vector(s) from right ascension and declination [rad]; shape (..., 3)."""
    ra, dec = np.asarray(ra_rad, dtype=float), np.asarray(dec_rad, dtype=float)
    cd = np.cos(dec)
    return np.stack([cd * np.cos(ra), cd * np.sin(ra), np.sin(dec)], axis=-1)


def unit_to_radec(v) -> tuple[np.ndarray, np.ndarray]:
    """(RA in [0, 2 pi), Dec) [rad] of direction(s) v."""
    u = unit(v)
    ra = np.mod(np.arctan2(u[..., 1], u[..., 0]), 2 * np.pi)
    dec = np.arcsin(np.clip(u[..., 2], -1.0, 1.0))
    return ra, dec


def pole_frame(ra_rad: float, dec_rad: float) -> np.ndarray:
    """Rotation matrix whose columns are the x, y, z axes (in ICRF) of a body equator frame.

    z is the pole (RA, Dec); x is the ascending node of the body equator on the ICRF equator
    (direction RA + 90 deg, Dec 0), the IAU convention. ``v_icrf = M @ v_body_equator``.
    """
    z = radec_to_unit(ra_rad, dec_rad)
    x = np.array([np.cos(ra_rad + np.pi / 2), np.sin(ra_rad + np.pi / 2), 0.0])
    y = np.cross(z, x)
    return np.column_stack([x, y, z])

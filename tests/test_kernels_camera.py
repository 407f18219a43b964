"""The compiled pinhole-camera kernel against the numpy camera model it replaced
(tests/reference_optical.py)."""

from __future__ import annotations

import numpy as np
import pytest

from fsw.astro.frames import matrix_to_quat
from fsw.models.environment import Environment
from fsw.models.optical import GeometryError, optical
from reference_optical import reference_optical

ENV = Environment()
T0 = 5.98e8


def _boresight_attitude(los: np.ndarray) -> np.ndarray:
    z = los / np.linalg.norm(los)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    return matrix_to_quat(np.column_stack([x, np.cross(z, x), z]))


@pytest.mark.parametrize("target", ["mars", "phobos", "deimos"])
@pytest.mark.parametrize("seed", range(3))
def test_camera_kernel_matches_numpy_reference(target, seed):
    rng = np.random.default_rng(seed)
    N = 3
    t = T0 + rng.uniform(0.0, 86400.0 * 20)
    r = rng.normal(0.0, 2e4, (N, 3)) + np.array([3e4, -2e4, 1e4])
    v = rng.normal(0.0, 3.0, (N, 3))
    r_T, _ = ENV.target_state(target, t)
    q = _boresight_attitude(r_T - r[0] + rng.normal(0.0, 50.0, 3))
    focal = rng.uniform(2e3, 1e4, N)
    pp = rng.uniform(400.0, 600.0, (N, 2))
    lt = np.array([True, False, seed % 2 == 0])
    ab = np.array([seed == 2, False, True])
    got = optical(ENV, target, t, r, v, q, focal, pp, lt, ab)
    ref = reference_optical(ENV, target, t, r, v, q, focal, pp, lt, ab)
    assert np.allclose(got[0], ref[0], rtol=1e-13, atol=1e-9)
    for a, b in zip(got[1:], ref[1:]):
        assert np.allclose(a, b, rtol=1e-11, atol=1e-14 * np.abs(b).max())


def test_target_behind_the_camera_is_a_geometry_error():
    t = T0
    r = np.array([[3e4, -2e4, 1e4]])
    q = _boresight_attitude(-(ENV.target_state("mars", t)[0] - r[0]))
    args = (np.array([5e3]), np.array([[512.0, 512.0]]), np.array([True]), np.array([False]))
    with pytest.raises(GeometryError, match="behind the camera"):
        optical(ENV, "mars", t, r, np.zeros((1, 3)), q, *args)
    with pytest.raises(GeometryError, match="behind the camera"):
        reference_optical(ENV, "mars", t, r, np.zeros((1, 3)), q, *args)

"""Rotation functions against hand-built rotations."""

import math

import numpy as np
import pytest

from fsw.astro import frames as fr


def test_rot_z_is_passive():
    # Frame rotated +90 deg about z: the old x axis has coordinates (0, -1, 0).
    assert np.allclose(fr.rot_z(math.pi / 2) @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0])
    assert np.allclose(fr.rot_x(math.pi / 2) @ [0.0, 1.0, 0.0], [0.0, 0.0, -1.0])
    assert np.allclose(fr.rot_y(math.pi / 2) @ [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0])
    assert fr.rot_z(np.zeros(4)).shape == (4, 3, 3)


def test_quaternion_matrix_round_trip_and_hand_case():
    q = fr.axis_angle_to_quat([0, 0, 1], math.pi / 2)  # active +90 deg about z
    assert np.allclose(fr.quat_to_matrix(q) @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q = q if q[0] >= 0 else -q
        assert np.allclose(fr.matrix_to_quat(fr.quat_to_matrix(q)), q, atol=1e-12)
    p, q = rng.normal(size=4), rng.normal(size=4)
    assert np.allclose(fr.quat_to_matrix(fr.quat_multiply(p, q)), fr.quat_to_matrix(p) @ fr.quat_to_matrix(q))
    assert np.allclose(fr.quat_to_matrix(fr.quat_conjugate(p)), fr.quat_to_matrix(p).T)


def test_radec_round_trip():
    ra, dec = np.radians([10.0, 200.0, 359.0]), np.radians([-80.0, 0.0, 45.0])
    u = fr.radec_to_unit(ra, dec)
    ra2, dec2 = fr.unit_to_radec(u)
    assert np.allclose(ra2, ra) and np.allclose(dec2, dec)
    assert np.allclose(fr.radec_to_unit(math.pi / 2, 0.0), [0, 1, 0], atol=1e-15)


def test_bad_input():
    with pytest.raises(fr.FrameError):
        fr.quat_to_matrix([0, 0, 0, 0])
    with pytest.raises(fr.FrameError):
        fr.quat_to_matrix([1, 0, 0])
    with pytest.raises(fr.FrameError):
        fr.unit([0, 0, 0])
    with pytest.raises(fr.FrameError):
        fr.matrix_to_quat(np.diag([1.0, 1.0, -1.0]))


def test_one_quaternion_is_the_batched_form_to_the_bit():
    """One attitude (an optical measurement's) takes a Python-float path; it must give what the
    numpy form of a batch gives for the same quaternion, including unnormalised ones."""
    rng = np.random.default_rng(7)
    q = rng.normal(size=(2000, 4)) * 10.0 ** rng.uniform(-4, 4, size=(2000, 1))
    q[::9, 2] = 0.0
    q[::13, 1] = -0.0
    batched = fr.quat_to_matrix(q)
    for k in range(len(q)):
        one = fr.quat_to_matrix(q[k])
        assert one.shape == (3, 3)
        assert np.array_equal(one, batched[k]) and np.array_equal(np.signbit(one), np.signbit(batched[k]))
    assert np.array_equal(fr.quat_to_matrix([0.0, 0.0, 0.0, 2.0]), np.diag([-1.0, -1.0, 1.0]))
    for bad in ([0.0, 0.0, 0.0, 0.0], [1.0, np.nan, 0.0, 0.0], [np.inf, 0.0, 0.0, 0.0]):
        with pytest.raises(fr.FrameError):
            fr.quat_to_matrix(bad)

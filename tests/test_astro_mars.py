"""Mars orientation: IAU 2009 prime meridian and pole by hand."""

import math

import numpy as np
import pytest

from fsw.astro import mars


def test_prime_meridian_by_hand():
    assert math.degrees(mars.prime_meridian_angle(0.0)) == pytest.approx(176.630, abs=1e-9)
    # One day later: 176.630 + 350.89198226 - 360 = 167.52198226 deg.
    assert math.degrees(mars.prime_meridian_angle(86400.0)) == pytest.approx(167.52198226, abs=1e-7)
    sidereal_day_h = 360.0 / 350.89198226 * 24.0
    assert sidereal_day_h == pytest.approx(24.6229, abs=1e-4)
    assert 2 * math.pi / mars.MARS_ROTATION_RATE_RAD_S / 3600 == pytest.approx(sidereal_day_h, rel=1e-12)


def test_body_fixed_frame_pole_and_meridian():
    M = mars.body_fixed_to_icrf_matrix(0.0)
    assert np.allclose(M.T @ M, np.eye(3), atol=1e-14)
    ra, dec = math.radians(317.68143), math.radians(52.88650)
    pole = np.array([math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)])
    assert np.allclose(M[:, 2], pole, atol=1e-14)
    # The node (RA + 90 deg) turned by W about the pole gives the prime meridian direction.
    node = np.array([math.cos(ra + math.pi / 2), math.sin(ra + math.pi / 2), 0.0])
    w = math.radians(176.630)
    expected = math.cos(w) * node + math.sin(w) * np.cross(pole, node)
    assert np.allclose(M[:, 0], expected, atol=1e-14)
    assert np.allclose(mars.areocentric_to_body_fixed(0.0, math.pi / 2, 10.0), [0.0, 10.0, 0.0], atol=1e-12)

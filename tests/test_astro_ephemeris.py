"""DE421 access: published distances, DE421 header constants, table accuracy, bad input."""

import numpy as np
import pytest

from fsw.astro import constants as c
from fsw.astro.ephemeris import EphemerisError, default_ephemeris
from fsw.astro.time import utc_iso_to_tdb


@pytest.fixture(scope="module")
def eph():
    return default_ephemeris()


def test_earth_mars_closest_approach_2018(eph):
    # NASA: closest approach 2018-07-31 ~07:50 UTC at 57.6 million km (35.8 million miles).
    t = utc_iso_to_tdb("2018-07-31T07:50:00")
    d = np.linalg.norm(eph.position("earth", t, "mars"))
    assert d == pytest.approx(57.59e6, abs=0.05e6)
    # ... and it is a minimum.
    ds = [np.linalg.norm(eph.position("earth", t + k * 86400.0, "mars")) for k in (-2, 2)]
    assert min(ds) > d


def test_mars_perihelion_2018(eph):
    # Mars perihelion 2018-09-16 at 1.3814 AU (206.6 million km).
    t = utc_iso_to_tdb("2018-09-16T00:00:00")
    r = np.linalg.norm(eph.position("mars", t, "sun"))
    assert r / c.AU_KM == pytest.approx(1.3814, abs=0.0005)
    rs = [np.linalg.norm(eph.position("mars", t + k * 86400.0 * 5, "sun")) for k in (-1, 1)]
    assert min(rs) > r


def test_gm_constants_match_de421_header(eph):
    au, day = eph.constant("AU"), 86400.0
    k = au**3 / day**2
    assert c.GM_SUN == pytest.approx(eph.constant("GMS") * k, rel=1e-10)
    assert c.GM_MARS_SYSTEM == pytest.approx(eph.constant("GM4") * k, rel=1e-9)
    assert c.GM_JUPITER_SYSTEM == pytest.approx(eph.constant("GM5") * k, rel=1e-9)
    assert c.GM_EARTH_MOON == pytest.approx(eph.constant("GMB") * k, rel=1e-9)
    assert c.GM_EARTH / c.GM_MOON == pytest.approx(eph.constant("EMRAT"), rel=1e-9)
    # one-way uplink Doppler: c / 7.15 GHz per mHz (the 8.4 GHz downlink carrier would give 3.569e-8)
    assert c.MHZ_TO_KM_S == pytest.approx(4.193e-8, rel=1e-3)


def test_velocity_is_derivative_of_position(eph):
    t = utc_iso_to_tdb("2018-11-01T00:00:00")
    for body in ("earth", "sun", "jupiter", "moon"):
        h = 10.0
        fd = (eph.position(body, t + h) - eph.position(body, t - h)) / (2 * h)
        assert np.max(np.abs(fd - eph.state(body, t)[1])) < 1e-8


def test_table_matches_direct_evaluation(eph):
    t0 = utc_iso_to_tdb("2018-10-12T19:47:00")
    t1 = t0 + 45 * 86400.0
    tab = eph.table(t0, t1, bodies=("sun", "earth", "jupiter", "moon"))
    t = np.random.default_rng(3).uniform(t0, t1, 500)
    p, v = tab.states(t)
    for k, body in enumerate(tab.bodies):
        pd, vd = eph.state(body, t, "mars")
        assert np.max(np.abs(p[:, k] - pd)) < 1e-6  # km
        # km/s; the Moon's fast geocentric motion makes it the worst tabulated body
        assert np.max(np.abs(v[:, k] - vd)) < (3e-9 if body == "moon" else 1e-9)
    assert np.allclose(tab.positions(float(t[0])), p[0], atol=1e-9, rtol=0)
    pe, _ = tab.state("earth", t[:3], "mars")
    assert pe.shape == (3, 3)


def test_shapes_and_centres(eph):
    t = utc_iso_to_tdb("2018-11-01T00:00:00")
    p, v = eph.state("earth", t, "ssb")
    assert p.shape == (3,) and v.shape == (3,)
    p2, _ = eph.state("earth", np.array([t, t + 1.0]), "ssb")
    assert p2.shape == (2, 3)
    a = eph.position("earth", t, "mars") + eph.position("mars", t, "sun")
    assert np.allclose(a, eph.position("earth", t, "sun"), atol=1e-6, rtol=0)


def test_bad_input_is_rejected(eph):
    with pytest.raises(EphemerisError):
        eph.state("pluto", 0.0)
    with pytest.raises(EphemerisError):
        eph.state("earth", 0.0, center="vulcan")
    with pytest.raises(EphemerisError):
        eph.state("earth", np.nan)
    with pytest.raises(EphemerisError):
        eph.state("earth", 1e11)
    tab = eph.table(0.0, 86400.0, bodies=("earth",))
    with pytest.raises(EphemerisError):
        tab.positions(10 * 86400.0)
    with pytest.raises(EphemerisError):
        tab.state("sun", 0.0)
    with pytest.raises(EphemerisError):
        tab.state("earth", 0.0, center="ssb")

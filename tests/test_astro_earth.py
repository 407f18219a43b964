"""Earth orientation and DSN stations, checked by hand formulas and a classical precession model."""

import math
from fractions import Fraction

import numpy as np
import pytest

from fsw.astro import earth, stations
from fsw.astro.ephemeris import default_ephemeris
from fsw.astro.frames import radec_to_unit, rot_y, rot_z, rot_x
from fsw.astro.time import utc_iso_to_tdb


def _era_by_hand(du: Fraction) -> float:
    turns = Fraction("0.7790572732640") + Fraction("1.00273781191135448") * du
    return float(turns - math.floor(turns)) * 2 * math.pi


def test_era_at_j2000_and_at_entry():
    assert math.degrees(earth.era_from_ut1_days(0.0)) == pytest.approx(280.46061837504, abs=1e-9)
    # 2018-11-26T19:47:00 UTC, UT1 = UTC: JD 2458448.5 + 19h47m.
    du = Fraction(24584485, 10) - 2451545 + Fraction(19 * 3600 + 47 * 60, 86400)
    t = utc_iso_to_tdb("2018-11-26T19:47:00")
    assert earth.earth_rotation_angle(t, dut1_s=0.0) == pytest.approx(_era_by_hand(du), abs=1e-10)


def test_cip_against_iau1976_precession_and_1980_nutation():
    t = utc_iso_to_tdb("2018-11-26T19:47:00")
    T = t / (86400 * 36525.0)
    asec = math.pi / 648000
    zeta = (2306.2181 * T + 0.30188 * T**2 + 0.017998 * T**3) * asec
    z = (2306.2181 * T + 1.09468 * T**2 + 0.018203 * T**3) * asec
    theta = (2004.3109 * T - 0.42665 * T**2 - 0.041833 * T**3) * asec
    P = rot_z(-z) @ rot_y(theta) @ rot_z(-zeta)
    lp = math.radians(357.52910918 + 35999.0502909 * T)
    F = math.radians(93.27209062 + 483202.0175381 * T)
    D = math.radians(297.85019547 + 445267.1114469 * T)
    Om = math.radians(125.04455501 - 1934.1361851 * T)
    dpsi = (-17.1996 * math.sin(Om) - 1.3187 * math.sin(2 * F - 2 * D + 2 * Om)
            - 0.2274 * math.sin(2 * F + 2 * Om) + 0.2062 * math.sin(2 * Om) + 0.1426 * math.sin(lp)) * asec
    deps = (9.2025 * math.cos(Om) + 0.5736 * math.cos(2 * F - 2 * D + 2 * Om)
            + 0.0977 * math.cos(2 * F + 2 * Om) - 0.0895 * math.cos(2 * Om)) * asec
    eps = (84381.448 - 46.8150 * T) * asec
    N = rot_x(-(eps + deps)) @ rot_z(-dpsi) @ rot_x(eps)
    pole = (N @ P).T @ np.array([0.0, 0.0, 1.0])
    X, Y = earth.cip_xy(t)
    assert abs(X - pole[0]) / asec < 0.5
    assert abs(Y - pole[1]) / asec < 0.5
    assert 300 < X / asec < 450  # ~19 years of precession: the reason Q is not ignored


def test_station_geodetic_coordinates_published():
    # DSN 810-005 module 301 geodetic values.
    for name, lat, lon in (("goldstone", 35.4259, -116.8895), ("canberra", -35.4024, 148.9813),
                           ("madrid", 40.4312, -4.2480)):
        g = stations.station(name).geodetic
        assert g[0] == pytest.approx(lat, abs=2e-4)
        assert g[1] == pytest.approx(lon, abs=2e-4)
        assert 0.5 < g[2] < 1.1


def test_elevation_hand_cases():
    t = utc_iso_to_tdb("2018-11-26T19:47:00")
    lat, lon, _ = stations.station("DSS-14").geodetic
    far = 1e9
    # Celestial pole: elevation = geodetic latitude (minus the <= 0.1 deg CIP offset from ICRF z).
    el = stations.elevation("DSS-14", t, np.array([0.0, 0.0, far]))
    assert math.degrees(el) == pytest.approx(lat, abs=0.15)
    # A star on the local meridian on the equator: RA = ERA + east longitude, elevation 90 - lat.
    ra = earth.earth_rotation_angle(t) + math.radians(lon)
    el = stations.elevation("goldstone", t, far * radec_to_unit(ra, 0.0))
    assert math.degrees(el) == pytest.approx(90 - lat, abs=0.15)
    # Below the horizon 12 hours of hour angle later.
    el = stations.elevation("goldstone", t, far * radec_to_unit(ra + math.pi, 0.0))
    assert math.degrees(el) == pytest.approx(-(90 - lat), abs=0.15)


def test_station_velocity_is_derivative_and_rotation_speed():
    t = utc_iso_to_tdb("2018-11-20T00:00:00") + np.array([0.0, 3600.0])
    p, v = stations.station_state_icrf("dss43", t)
    # Five-point stencil; h large enough that the 0.1 us resolution of t_tdb does not dominate.
    h = 20.0
    pos = [stations.station_state_icrf("dss43", t + k * h)[0] for k in (-2, -1, 1, 2)]
    fd = (pos[0] - 8 * pos[1] + 8 * pos[2] - pos[3]) / (12 * h)
    assert np.max(np.abs(fd - v)) < 2e-9
    r_axis = math.hypot(*stations.station("dss43").itrs_km[:2])
    assert np.linalg.norm(v, axis=1) == pytest.approx(r_axis * 7.2921159e-5, rel=1e-3)


def test_station_state_mars_adds_earth():
    eph = default_ephemeris()
    t = utc_iso_to_tdb("2018-11-20T00:00:00")
    ps, vs = stations.station_state_mars("madrid", t)
    pe, ve = eph.state("earth", t, "mars")
    assert np.linalg.norm(ps - pe) == pytest.approx(np.linalg.norm(stations.station("madrid").itrs_at(t)), rel=1e-12)
    tab = eph.table(t - 86400, t + 86400, bodies=("earth",))
    pt, _ = stations.station_state_mars("madrid", t, ephemeris=tab)
    assert np.allclose(pt, ps, atol=1e-6, rtol=0)


def test_unknown_station_rejected():
    with pytest.raises(stations.StationError):
        stations.station("arecibo")
    with pytest.raises(stations.StationError):
        stations.elevation("dss14", 0.0, np.array([1.0, 2.0]))


def test_station_velocity_is_smooth_through_a_leap_second():
    # UT1-UTC steps by 1 s at 1997-07-01; the ERA rate must come from UT1-TAI, which does not
    t = utc_iso_to_tdb("1997-06-30T23:59:30") + np.array([0.0, 20.0, 40.0, 60.0, 80.0])
    _, v = stations.station_state_icrf("dss14", t)
    speed = np.linalg.norm(v, axis=1)
    assert np.ptp(speed) < 1e-9  # km/s
    assert abs(earth.ut1_rate(t[2])) < 1e-7


def test_rotation_chain_of_many_epochs_is_that_of_each_epoch():
    """The chain evaluates the epochs, their ±1 h precession-nutation neighbours (on this
    10-minute grid most of them grid epochs, evaluated once) and the UT1 slope's ±60 s lookups in
    one array: each epoch's result must be the one it gets alone."""
    r = stations.station("DSS-43").itrs_at(np.zeros(1))[0]
    t = utc_iso_to_tdb("2018-11-20T00:00:00") + 600.0 * np.arange(30) + 17.25
    pos, vel, pole = earth.itrs_to_gcrs_state_and_pole(r, t)
    for k in (0, 7, 29):
        p1, v1, k1 = earth.itrs_to_gcrs_state_and_pole(r, t[k:k + 1])
        assert np.array_equal(p1[0], pos[k]) and np.array_equal(v1[0], vel[k]) and np.array_equal(k1[0], pole[k])
        ps, vs = earth.itrs_to_gcrs_state(r, float(t[k]))
        assert ps.shape == (3,) and np.array_equal(ps, pos[k]) and np.array_equal(vs, vel[k])
    # the UT1 slope is the central difference of the uploaded UT1-TAI, epoch by epoch
    _, hi = earth._eop_and_ut1_tai(t + 60.0)
    _, lo = earth._eop_and_ut1_tai(t - 60.0)
    assert np.array_equal(earth.ut1_rate(t), (hi - lo) / 120.0)
    assert np.ndim(earth.ut1_rate(float(t[3]))) == 0 and earth.ut1_rate(float(t[3])) == ((hi - lo) / 120.0)[3]

"""The simulator's truth models against independent numbers, and their distance from the onboard models."""

import math

import numpy as np
import pytest

from sim.truth import eop, moons, stations, timescales as ts
from sim.truth.earth import EarthOrientation, EarthOrientationError, itrs_to_gcrs_direct

ENTRY = "2018-11-26T19:47:00"


def test_time_scales_at_insight_entry():
    t = ts.utc_iso_to_tdb(ENTRY)
    assert ts.tai_minus_utc(2018, 11, 26) == 37.0  # IERS Bulletin C: 37 s since 2017-01-01
    # TT - UTC = 37 + 32.184 s; TDB - TT = -1.034 ms on that date (Fairhead & Bretagnon series)
    assert ts.tdb_minus_tt(t) == pytest.approx(-1.0347e-3, abs=2e-7)
    # UTC seconds past 2000-01-01T12:00:00: 6904 days and 7 h 47 min
    assert ts.tdb_to_tt(t) - 69.184 == pytest.approx(6904 * 86400.0 + 7 * 3600 + 47 * 60, abs=1e-6)
    assert ts.tdb_to_unix(t) == pytest.approx(1543261620.0, abs=1e-6)  # date -d 2018-11-26T19:47:00Z +%s


def test_leap_second_of_1997_and_bad_text():
    before = ts.utc_iso_to_tdb("1997-06-30T23:59:59")
    assert ts.utc_iso_to_tdb("1997-07-01T00:00:00") - before == pytest.approx(2.0, abs=1e-9)  # 23:59:60 existed
    assert ts.tdb_to_unix(ts.utc_iso_to_tdb("1997-07-01T00:00:01")) == pytest.approx(867715201.0, abs=1e-6)
    with pytest.raises(ts.TruthTimeError):
        ts.utc_iso_to_tdb("2018-13-45")
    with pytest.raises(ts.TruthTimeError):
        ts.tdb_to_unix(float("nan"))


def test_eop_is_continuous_through_a_leap_second_and_refuses_outside_the_table():
    tai = ts.tdb_to_tai(ts.utc_iso_to_tdb("1997-07-01T00:00:00"))
    e = eop.eop_at_tai(np.array([tai - 3600.0, tai + 3600.0]))
    # UT1-TAI moves by the length of day (~ms), not by the 1 s step of UT1-UTC
    assert abs(e.ut1_minus_tai[1] - e.ut1_minus_tai[0]) < 1e-4
    assert -1.0 < e.ut1_minus_tai[0] + 31.0 < 1.0  # TAI-UTC was 31 s before the step
    with pytest.raises(eop.EopError):
        eop.eop_at_tai(ts.tdb_to_tai(ts.utc_iso_to_tdb("2010-01-01T00:00:00")))


def test_interpolated_orientation_matches_erfa_at_each_epoch():
    t0 = ts.utc_iso_to_tdb("2018-10-12T00:00:00")
    eo = EarthOrientation(t0, t0 + 45 * 86400.0)
    r = stations.station("DSS-14").itrs_km(t0)
    for t in t0 + np.array([0.0, 1234.5, 17.3 * 86400.0, 44.9 * 86400.0]):
        m, _ = eo.matrices(np.array([t]))
        assert np.linalg.norm((m[0] - itrs_to_gcrs_direct(t)) @ r) < 1e-6  # < 1 mm
        # against ERFA's c2t06a, which knows no observed pole offsets: they are < 0.5 mas (< 2 cm)
        assert np.linalg.norm((m[0] - itrs_to_gcrs_direct(t, pole_offsets=False)) @ r) < 2e-5
    with pytest.raises(EarthOrientationError):
        eo.matrices(np.array([t0 + 50 * 86400.0]))


def test_station_gcrs_magnitude_and_rotation_speed():
    t0 = ts.utc_iso_to_tdb("2018-11-20T00:00:00")
    eo = EarthOrientation(t0, t0 + 86400.0)
    t = t0 + np.linspace(0.0, 86400.0, 7)
    st = stations.station("canberra")
    r = st.itrs_km(t)
    p, v = eo.state(r[..., None], t)
    assert np.allclose(np.linalg.norm(p[..., 0], axis=1), np.linalg.norm(r, axis=1), rtol=0, atol=1e-9)
    r_axis = math.hypot(*r[0, :2])
    assert np.linalg.norm(v[..., 0], axis=1) == pytest.approx(r_axis * 7.2921150e-5, rel=2e-4)
    h = 2.0
    fd = (eo.state(r[..., None], t + h)[0] - eo.state(r[..., None], t - h)[0]) / (2 * h)
    assert np.max(np.abs(fd - v)) < 5e-8  # km/s; rounding of ERA at 2 s steps dominates
    # plate motion: Canberra moved 0.8 m between 2003.0 and late 2018 (810-005 301 velocities)
    assert np.linalg.norm(st.itrs_km(t0) - np.array(st.itrs_2003_m) * 1e-3) * 1e3 == pytest.approx(0.82, abs=0.02)


def test_phobos_and_deimos_follow_the_published_periods():
    t = 5.96e8
    for name, period_d in (("phobos", 0.3189), ("deimos", 1.2624)):
        p0, _ = moons.moon_state(name, t)
        p1, _ = moons.moon_state(name, t + period_d * 86400.0)
        assert math.degrees(math.acos(p0 @ p1 / np.linalg.norm(p0) / np.linalg.norm(p1))) < 0.5
        a = moons.MOONS[name].a_km
        assert 0.97 * a < np.linalg.norm(p0) < 1.03 * a
    assert 7.6 < 0.3189 * 24 < 7.7  # the 7.65 h of DESIGN.md


def test_truth_and_onboard_differ_by_the_documented_amounts():
    from tools.validation.model_differences import measure

    diffs = {(d.model, d.quantity): d for d in measure("2018-10-12T00:00:00", 45.0, step_s=3600.0)}
    tdb = diffs[("time", "TDB-TT (onboard 7-term series vs Fairhead & Bretagnon)")]
    assert 0.5 < tdb.maximum < 10.0  # us
    for name in ("DSS-14", "DSS-43", "DSS-63"):
        pos = diffs[("Earth orientation", f"GCRS position of {name}'s ITRS point")]
        vel = diffs[("Earth orientation", f"GCRS velocity of {name}'s ITRS point")]
        assert 0.005 < pos.maximum < 0.05  # m: IAU 2000B and the linearly interpolated daily EOP vs 2006/2000A
        assert 0.0003 < vel.maximum < 0.005  # mm/s, 1 % of the 0.1 mm/s Doppler noise
    for moon in ("phobos", "deimos"):
        assert 0.01 < diffs[("moons", f"{moon} position")].maximum < 1.0  # m
    pole = diffs[("Mars orientation", "north pole direction (onboard fixed at J2000, truth drifting)")]
    assert 0.01 < pole.maximum < 0.03  # deg


def test_many_epoch_tdb_to_tt_is_bit_identical_to_the_direct_series():
    import erfa
    from sim.truth import timescales
    rng = np.random.default_rng(5)
    for lo, span in ((5.9e8, 45 * 86400.0), (-2e8, 3e6), (1.2e9, 1e6), (0.0, 8e5)):
        t = rng.uniform(lo, lo + span, 30000)
        direct = t - np.asarray(erfa.dtdb(timescales.JD_J2000, t / 86400.0, 0.0, 0.0, 0.0, 0.0))
        assert np.array_equal(timescales.tdb_to_tt(t), direct)


def test_hourly_cubic_of_tdb_minus_tt_is_far_inside_the_bound_the_shortcut_assumes():
    import erfa
    from sim.truth import timescales
    t = np.linspace(-3e8, 1.5e9, 400001) + 1234.5
    k0 = np.floor(t.min() / 3600.0) - 1
    x = t / 3600.0 - k0
    k = np.floor(x).astype(np.int64)
    u = x - k
    nodes = np.asarray(erfa.dtdb(timescales.JD_J2000, (k0 + np.arange(k.max() + 3)) * 3600.0 / 86400.0, 0.0, 0.0, 0.0, 0.0))
    p0, p1, p2, p3 = nodes[k - 1], nodes[k], nodes[k + 1], nodes[k + 2]
    d = (-u * (u - 1) * (u - 2) / 6 * p0 + (u + 1) * (u - 1) * (u - 2) / 2 * p1
         - (u + 1) * u * (u - 2) / 2 * p2 + (u + 1) * u * (u - 1) / 6 * p3)
    err = np.abs(d - np.asarray(erfa.dtdb(timescales.JD_J2000, t / 86400.0, 0.0, 0.0, 0.0, 0.0)))
    assert err.max() < 1e-3 * timescales._BOUND_S

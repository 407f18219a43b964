"""Time scales: independent checks against hand values, Python's datetime and a second TDB-TT series."""

import datetime as dt
import math

import numpy as np
import pytest

from fsw.astro import time as ts


def test_tt_minus_utc_in_2018_is_69_184():
    t = ts.utc_iso_to_tdb("2018-11-26T19:47:00")
    naive = ts.utc_iso_to_naive("2018-11-26T19:47:00")
    assert ts.tdb_to_tt(t) - naive == pytest.approx(69.184, abs=1e-6)


def test_entry_epoch_julian_date_by_hand():
    # JD(UTC) of 2018-11-26 00:00 is 2458448.5; 19:47 = 0.824305.. day; TT = UTC + 69.184 s.
    jd_tt = 2458448.5 + (19 * 3600 + 47 * 60 + 69.184) / 86400.0
    t_tt = ts.tdb_to_tt(ts.utc_iso_to_tdb("2018-11-26T19:47:00"))
    assert 2451545.0 + t_tt / 86400.0 == pytest.approx(jd_tt, abs=1e-9)


def test_j2000_epoch_in_utc():
    # J2000.0 = 2000-01-01T12:00:00 TT = 11:58:55.816 UTC; TDB-TT there is about -0.1 ms.
    assert ts.tdb_to_tt(ts.utc_iso_to_tdb("2000-01-01T11:58:55.816")) == pytest.approx(0.0, abs=1e-9)


def test_tdb_minus_tt_against_two_term_series():
    # Independent low-order form: 0.001657 sin g + 0.000014 sin 2g (Explanatory Supplement).
    t_tt = np.linspace(-3e8, 8e8, 500)
    d = t_tt / 86400.0
    g = np.radians(357.53 + 0.98560028 * d)
    simple = 0.001657 * np.sin(g) + 0.000014 * np.sin(2 * g)
    assert np.max(np.abs(ts.tdb_minus_tt(t_tt) - simple)) < 5e-5
    assert np.max(np.abs(ts.tdb_minus_tt(t_tt))) < 1.72e-3


def test_round_trips_iso_tdb_unix():
    for s in ["1999-12-31T23:59:59.250", "2018-10-12T00:00:00.000", "2018-11-26T19:47:00.123",
              "2024-02-29T06:30:15.500"]:
        t = ts.utc_iso_to_tdb(s)
        assert ts.tdb_to_utc_iso(t) == s
        assert ts.unix_to_tdb(ts.tdb_to_unix(t)) == pytest.approx(t, abs=1e-6)
    t = np.linspace(5.9e8, 6.0e8, 50)
    assert np.allclose(ts.unix_to_tdb(ts.tdb_to_unix(t)), t, atol=1e-6, rtol=0)


def test_unix_matches_python_datetime():
    s = "2018-11-26T19:47:00"
    expected = dt.datetime(2018, 11, 26, 19, 47, tzinfo=dt.timezone.utc).timestamp()
    assert ts.tdb_to_unix(ts.utc_iso_to_tdb(s)) == pytest.approx(expected, abs=1e-6)


def test_leap_second_is_counted():
    a = ts.utc_iso_to_tdb("2016-12-31T23:59:59")
    b = ts.utc_iso_to_tdb("2017-01-01T00:00:00")
    assert b - a == pytest.approx(2.0, abs=1e-6)  # 23:59:60 lies between them
    assert ts.tdb_to_utc_iso(a + 1.25) == "2016-12-31T23:59:60.250"


def test_bad_input_is_rejected():
    for bad in ["2018-13-01T00:00:00", "2018-02-30T00:00:00", "yesterday", "2018-11-26T25:00:00",
                "2018-11-26T23:59:60"]:
        with pytest.raises(ts.TimeError):
            ts.utc_iso_to_tdb(bad)
    with pytest.raises(ts.TimeError):
        ts.utc_iso_to_tdb("1960-01-01T00:00:00")
    with pytest.raises(ts.TimeError):
        ts.tdb_to_utc_iso(math.nan)
    with pytest.raises(ts.TimeError):
        ts.tdb_to_unix(np.array([0.0, np.inf]))

"""Light time and station geometry against independent computations."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from fsw.astro.constants import C_KM_S
from fsw.astro.ephemeris import default_ephemeris
from sim.truth.earth import itrs_to_gcrs_direct
from sim.truth.stations import station
from sim.sensors.lighttime import LightTimeError, light_time
from sim.sensors.radiometric import uplink
from sim.sensors.geometry import Scene

T0 = 5.93e8  # ~2018-10 TDB


def test_static_geometry_light_time_is_distance_over_c():
    rx = np.array([[1.0e8, 2.0e7, -3.0e6], [0.0, 0.0, 7.0e7]])
    tx = np.array([[1.0e3, -5.0e3, 2.0e3], [1.0, 2.0, 3.0]])
    t = np.array([T0, T0 + 10.0])
    tau, pos = light_time(t, rx, lambda tt: tx)
    np.testing.assert_allclose(tau, np.linalg.norm(rx - tx, axis=1) / C_KM_S, rtol=1e-15)
    np.testing.assert_array_equal(pos, tx)


def test_moving_emitter_matches_brentq():
    # Emitter on a circular orbit (30 km/s) with a radial velocity component; receiver fixed.
    w = 2e-7

    def emitter(tt):
        tt = np.atleast_1d(tt)
        s = tt - T0
        return np.column_stack((1.5e8 * np.cos(w * s), 1.5e8 * np.sin(w * s), 20.0 * s))

    rx = np.array([[2.0e8, -1.0e8, 5.0e6]] * 3)
    t = T0 + np.array([0.0, 3.6e3, 8.64e4])
    tau, _ = light_time(t, rx, emitter)
    for k in range(3):
        # Solve for tau directly: t ~ 6e8 s has only 1e-7 s (36 m) of resolution.
        h = lambda tau_: np.linalg.norm(rx[k] - emitter(t[k] - tau_)[0]) - C_KM_S * tau_
        ref = brentq(h, 1.0, 5000.0, xtol=1e-14, rtol=1e-15)
        assert tau[k] == pytest.approx(ref, abs=1e-11)


def test_degenerate_geometry_is_rejected():
    with pytest.raises(LightTimeError):
        light_time(np.array([T0]), np.zeros((1, 3)), lambda tt: np.zeros((np.size(tt), 3)))
    with pytest.raises(LightTimeError):
        light_time(np.array([T0, T0]), np.zeros((1, 3)), lambda tt: np.zeros((2, 3)))


def test_uplink_matches_an_independent_station_computation():
    # Spacecraft fixed 1 AU-ish away in the Mars-centred frame; station from ITRS coordinates,
    # rotated with the Earth-orientation matrix, barycentric positions straight from DE421;
    # light time by brentq; elevation from the geodetic vertical computed here.
    eph = default_ephemeris()
    sc_mars = np.array([3.0e5, -2.0e6, 1.0e6])
    scene = Scene(lambda tt: np.tile(sc_mars, (np.size(tt), 1)), T0, T0 + 86400.0)
    t = T0 + np.array([1000.0, 30000.0, 61234.5])
    for name in ("DSS-14", "DSS-43", "DSS-63"):
        tau, el = uplink(scene, name, t)
        st = station(name)
        for k in range(t.size):
            r_sc = eph.position("mars", t[k], "ssb") + sc_mars

            def stn(tt):
                return eph.position("earth", tt, "ssb") + itrs_to_gcrs_direct(tt) @ st.itrs_km(tt)

            ref = brentq(lambda x: np.linalg.norm(r_sc - stn(t[k] - x)) - C_KM_S * x, 10.0, 3000.0, xtol=1e-13)
            assert tau[k] == pytest.approx(ref, abs=2e-10)
            t_tx = t[k] - ref
            up = itrs_to_gcrs_direct(t_tx) @ st.up_itrs(t_tx)
            los = r_sc - stn(t_tx)
            el_ref = math.asin(np.dot(los, up) / np.linalg.norm(los))
            assert el[k] == pytest.approx(el_ref, abs=1e-7)

"""One-way range and Doppler: independent recomputation, clock terms, noise, schedule."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from fsw.astro.constants import C_KM_S
from fsw.astro.ephemeris import default_ephemeris
from sim.truth.earth import itrs_to_gcrs_direct
from sim.truth.stations import station
from sim.sensors.config import RadiometricConfig
from sim.sensors.radiometric import make_schedule


@pytest.fixture(scope="module")
def sim_run():
    from sim.stream import generate

    return generate(seed=5)


def _reference_range(run, name, t):
    """c (tau + b) with tau from brentq on DE421 + ITRS station rotated to GCRS by ERFA, epoch by epoch.

    The station is evaluated at t_ref + (t - x - t_ref) by a Taylor step from the nearest whole
    second, so the result does not suffer from the 1.2e-7 s resolution of t ~ 6e8 s.
    """
    eph = default_ephemeris()
    st = station(name).itrs_km(t)
    r_sc = eph.position("mars", t, "ssb") + run.trajectory.position(t)
    t_whole = math.floor(t)
    frac = t - t_whole  # exact

    def stn(x):
        base = t_whole - math.floor(x)  # exact integer seconds
        dt = frac - (x - math.floor(x))  # small, precise
        h = 10.0
        pe, ve = eph.state("earth", base, "ssb")
        ae = (eph.state("earth", base + h, "ssb")[1] - eph.state("earth", base - h, "ssb")[1]) / (2 * h)
        M0, Mp, Mm = itrs_to_gcrs_direct(base), itrs_to_gcrs_direct(base + h), itrs_to_gcrs_direct(base - h)
        ps = M0 @ st
        vs = (Mp - Mm) @ st / (2 * h)
        acc = (Mp - 2 * M0 + Mm) @ st / h**2
        return pe + ve * dt + 0.5 * ae * dt * dt + ps + vs * dt + 0.5 * acc * dt * dt

    tau = brentq(lambda x: np.linalg.norm(r_sc - stn(x)) - C_KM_S * x, 10.0, 3000.0, xtol=1e-13)
    return C_KM_S * (tau + run.clock.phase(t))


def test_range_and_doppler_match_an_independent_computation(sim_run):
    run = sim_run
    r = run.radio
    rng_idx = np.flatnonzero(r.kind == "range")[:: max(1, int(np.sum(r.kind == "range")) // 8)]
    for i in rng_idx:
        assert r.clean[i] - r.range_bias_km == pytest.approx(_reference_range(run, r.station[i], r.t_rx[i]), abs=5e-6)
    dop_idx = np.flatnonzero(r.kind == "doppler")[:: max(1, int(np.sum(r.kind == "doppler")) // 8)]
    for i in dop_idx:
        t = r.t_rx[i]
        ref = (_reference_range(run, r.station[i], t) - _reference_range(run, r.station[i], t - 60.0)) / 60.0
        # float64 resolves a 1e8 km range to ~3e-8 km, i.e. 5e-10 km/s over a 60 s count.
        assert r.clean[i] == pytest.approx(ref, abs=2e-9)


def test_clock_errors_appear_as_c_times_phase_and_frequency(sim_run):
    run = sim_run
    r = run.radio
    rg = np.flatnonzero(r.kind == "range")
    b = run.clock.phase(r.t_rx[rg])
    np.testing.assert_allclose(r.clean[rg] - r.range_bias_km - C_KM_S * r.light_time_s[rg], C_KM_S * b, rtol=0, atol=1e-6)
    # the run's station-delay bias is one draw of the configured 2 m dispersion, in range only
    assert r.range_bias_km != 0.0 and abs(r.range_bias_km) < 5 * 2e-3
    # Doppler minus the geometric range rate (differenced light time) is c x mean frequency.
    d = np.flatnonzero(r.kind == "doppler")[:50]
    t = r.t_rx[d]
    b1, b0 = run.clock.phase(t), run.clock.phase(t - 60.0)
    geometric = r.clean[d] - C_KM_S * (b1 - b0) / 60.0
    f = run.clock.state(t - 30.0)[1]
    np.testing.assert_allclose(r.clean[d] - geometric, C_KM_S * f, rtol=0, atol=C_KM_S * 2e-13)


def test_radio_noise_has_the_configured_sigma(sim_run):
    r = sim_run.radio
    for kind, sigma in (("range", 1e-3), ("doppler", 1e-7)):
        sel = r.kind == kind
        z = r.noise[sel] / sigma
        n = z.size
        np.testing.assert_allclose(r.sigma[sel], sigma)
        assert abs(float(np.sum(z * z)) - n) < 4 * math.sqrt(2 * n)
        assert abs(float(np.std(r.noise[sel])) / sigma - 1.0) < 4 / math.sqrt(2 * n)
    # The reported values carry exactly that noise (no fault in this run).
    meas = [m for m in sim_run.measurements if m.kind in ("range", "doppler")]
    idx = sim_run.index[sim_run.origin == "radio"]
    values = np.array([m.value[0] for m in meas])
    np.testing.assert_array_equal(values, r.clean[idx] + r.noise[idx])


def test_every_radio_measurement_is_above_ten_degrees(sim_run):
    assert np.degrees(sim_run.radio.elevation_rad.min()) >= 10.0
    assert set(sim_run.radio.station) <= {"DSS-14", "DSS-43", "DSS-63"}


def test_default_schedule():
    cfg = RadiometricConfig()
    s = make_schedule(cfg, 0.0, 45 * 86400.0)
    assert s.pass_start.size == 135
    np.testing.assert_allclose(np.diff(s.pass_start), 8 * 3600.0)
    assert s.range_t.size == 135 * 19  # every 10 min over 3 h, both ends included
    assert s.doppler_t.size == 135 * 180  # counts ending every 60 s after the first minute
    assert np.all(s.doppler_t - 60.0 >= s.pass_start[s.doppler_pass])
    assert np.all(s.doppler_t <= s.pass_end[s.doppler_pass])
    none = make_schedule(RadiometricConfig(passes_per_day=0), 0.0, 86400.0)
    assert none.range_t.size == 0 and none.doppler_t.size == 0
    with pytest.raises(ValueError):
        RadiometricConfig(passes_per_day=9, pass_duration_h=3.0)

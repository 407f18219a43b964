"""Onboard one-way range and Doppler geometry against a brute-force light-time solution.

The reference iterates the light-time equation to convergence with the station from the full
Earth-rotation chain (:func:`fsw.astro.stations.station_state_icrf`) and the Earth and Mars
straight from DE421 at every iterate — none of the onboard shortcuts (station grid and
rotation, ephemeris table, expansion about a reference transmit epoch, fixed iteration count).
"""

from __future__ import annotations

import numpy as np
import pytest

from fsw.astro.constants import C_KM_S
from fsw.astro.ephemeris import default_ephemeris
from fsw.astro.stations import station_state_icrf
from fsw.filters.config import BankConfig, FilterConfig
from fsw.filters.ekf import EKFStack
from fsw.models.environment import Environment
from fsw.models.radiometric import uplink, uplinks
from tools.bench.synthetic import entry_state

ENV = Environment()


def _reference_range(station: str, t: float, r_sc_ssb: np.ndarray, delta: float = 0.0) -> float:
    """Geometric range c·τ for a reception at TDB t − δ."""
    eph = default_ephemeris()
    tau = 0.0
    for _ in range(30):
        # epochs near 6e8 s resolve only ~1e-7 s (3 mm of Earth motion): evaluate at the
        # rounded transmit epoch and carry the emitter by its velocity over the rounding error
        t_tx = t - (delta + tau)
        e = (t - t_tx) - (delta + tau)
        earth, v_earth = eph.state("earth", t_tx, "ssb")
        st, v_st = station_state_icrf(station, t_tx)
        new = float(np.linalg.norm(r_sc_ssb - earth - st - (v_earth + v_st) * e)) / C_KM_S
        if abs(new - tau) < 1e-14:
            break
        tau = new
    return C_KM_S * tau


def _state(hours_before_entry: float) -> tuple[float, np.ndarray, np.ndarray]:
    t_e, r_e, v_e = entry_state()
    probe = EKFStack(BankConfig(filters=(FilterConfig(name="f"),)), t_e, r_e, v_e, ENV)
    t = t_e - hours_before_entry * 3600.0
    r, v, _ = probe.propagator.propagate(t_e, t, r_e[None], v_e[None], probe.drivers(), with_stm=False)
    return t, r, v


@pytest.mark.parametrize("station", ["DSS-14", "DSS-43", "DSS-63"])
@pytest.mark.parametrize("hours", [900.0, 40.0])
def test_range_matches_brute_force_light_time(station, hours):
    t, r, v = _state(hours)
    # three filters spread by up to 2000 km and with different clock phases
    r3 = r + np.array([[0.0, 0.0, 0.0], [1500.0, -800.0, 300.0], [-200.0, 900.0, -1200.0]])
    v3 = np.repeat(v, 3, axis=0)
    delta = np.array([0.0, 2e-6, -1e-6])
    g = uplink(ENV, station, t, r3, v3, delta)
    mars = default_ephemeris().state("mars", t, "ssb")
    for i in range(3):
        # reception at TDB t − δ for a clock reading t; spacecraft moved back to it to first order
        r_ssb = mars[0] + r3[i] - (v3[i] + mars[1]) * delta[i]
        # station grid (< 3e-7 km), ephemeris table, 2 light-time passes: far below the 1e-3 km noise
        assert g.rho[i] == pytest.approx(_reference_range(station, t, r_ssb, delta[i]), abs=5e-7)  # km


@pytest.mark.parametrize("hours", [600.0, 20.0])
def test_differenced_range_of_a_doppler_count_matches_brute_force(hours):
    t, r, v = _state(hours)
    T = 60.0
    probe = EKFStack(BankConfig(filters=(FilterConfig(name="f"),)), t, r[0], v[0], ENV)
    r_s, v_s, _ = probe.propagator.propagate(t, t - T, r, v, probe.drivers(), with_stm=False)
    g = uplinks(ENV, "DSS-43", (t, t - T), np.stack([r, r_s]), np.stack([v, v_s]), np.zeros(1))
    eph = default_ephemeris()
    ref = [_reference_range("DSS-43", tk, eph.state("mars", tk, "ssb")[0] + rk[0]) for tk, rk in ((t, r), (t - T, r_s))]
    # one-way Doppler noise is 1e-7 km/s: the geometry must be far better
    assert (g.rho[0, 0] - g.rho[1, 0]) / T == pytest.approx((ref[0] - ref[1]) / T, abs=5e-10)


def test_states_many_is_the_table_interpolant_and_its_derivative():
    t = float(_state(100.0)[0])
    ts = (t, t - 61.25, t + 3333.0)
    p, v = ENV.states_many(ts)
    tab = ENV._table_for(min(ts), max(ts))
    for k, tk in enumerate(ts):
        np.testing.assert_allclose(p[k], tab.positions(tk), rtol=0, atol=1e-6)
        fd = (tab.positions(tk + 5.0) - tab.positions(tk - 5.0)) / 10.0  # smooth: central difference
        np.testing.assert_allclose(v[k], fd, rtol=0, atol=2e-8)

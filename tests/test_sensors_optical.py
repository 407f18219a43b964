"""Optical sensor: pinhole geometry, visibility rules, independent recomputation of centroids."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from fsw.astro.constants import C_KM_S, R_MARS_EQ_KM
from fsw.astro.ephemeris import default_ephemeris
from fsw.astro.asteroids import NAMES as BEACONS, beacon_state
from sim.truth.moons import moon_state
from sim.sensors.camera import CameraError, pointing_frame, project, small_rotation
from sim.sensors.config import OpticalConfig
from sim.sensors.optical import simulate_optical

T0 = 5.93e8
F_PX = 500e-3 / 12e-6


@pytest.fixture(scope="module")
def sim_run():
    from sim.stream import generate

    return generate(seed=11)


def quat_to_dcm(q):
    """Active rotation of a scalar-first Hamilton quaternion (written out independently)."""
    w, x, y, z = np.asarray(q) / np.linalg.norm(q)
    return np.array([
        [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
    ])


def test_pinhole_hand_case():
    # Boresight along ICRF +x: camera x (sample) = north x boresight = +y, camera y (line) = +z.
    C = pointing_frame(np.array([[1.0, 0.0, 0.0]]))
    np.testing.assert_allclose(C[0], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-15)
    th = 1e-3
    d = np.array([[math.cos(th), math.sin(th), 0.0], [math.cos(th), 0.0, -math.sin(th)], [1.0, 0.0, 0.0]])
    px = project(d, np.repeat(C, 3, axis=0), F_PX, (512.5, 512.5))
    np.testing.assert_allclose(px[0], [512.5 + F_PX * math.tan(th), 512.5], atol=1e-9)
    np.testing.assert_allclose(px[1], [512.5, 512.5 - F_PX * math.tan(th)], atol=1e-9)
    np.testing.assert_allclose(px[2], [512.5, 512.5], atol=1e-12)
    with pytest.raises(CameraError):
        project(-d[:1], C, F_PX, (512.5, 512.5))
    # A 5 urad rotation about camera y moves the target by f * 5e-6 px in sample.
    R = small_rotation(np.array([[0.0, 5e-6, 0.0]]))
    moved = project(d[2:], C @ R, F_PX, (512.5, 512.5))
    assert abs(moved[0, 0] - 512.5) == pytest.approx(F_PX * 5e-6, rel=1e-6)


class FakeScene:
    """Static scene: spacecraft at the origin, Mars at ``mars``, Sun at ``sun``, moons fixed."""

    def __init__(self, mars, sun, moons):
        self._p = {"mars": np.asarray(mars, float), "sun": np.asarray(sun, float)}
        self._moons = {k: np.asarray(v, float) for k, v in moons.items()}

    def sc(self, t):
        return np.zeros((np.size(t), 3))

    def body(self, name, t):
        return np.tile(self._p[name], (np.size(t), 1))

    def target(self, name):
        p = self._p["mars"] if name == "mars" else self._p["mars"] + self._moons[name]
        return lambda t: np.tile(p, (np.size(t), 1))

    def target_velocity(self, name):
        return lambda t: np.zeros((np.size(t), 3))


def _run(scene, **kw):
    kw.setdefault("beacons", ())
    cfg = OpticalConfig(**kw)
    return simulate_optical(cfg, scene, T0, T0 + 10 * 1800.0, np.random.default_rng(0))


def test_visibility_rules():
    far = 1.0e7
    mars_dir = np.array([far, 0.0, 0.0])
    rho_px = math.asin(R_MARS_EQ_KM / far) * F_PX  # ~14 px apparent radius
    sun_away = -1.5e8 * np.array([1.0, 0.2, 0.0])
    sep_ok = (1.5 * rho_px + 5.0 + 3.0) / F_PX * far
    sep_glare = (1.5 * rho_px + 5.0 - 3.0) / F_PX * far
    moons = {"phobos": [0.0, sep_ok, 0.0], "deimos": [0.0, 0.0, sep_glare]}
    out = _run(FakeScene(mars_dir, sun_away, moons))
    assert set(out.target) == {"mars", "phobos"}  # deimos lost in the glare; slots fall to the next target
    assert len(out) == 10
    # Sun 20 deg from Mars: nothing can be imaged.
    sun_near = 1.5e8 * np.array([math.cos(math.radians(20)), math.sin(math.radians(20)), 0.0])
    assert len(_run(FakeScene(mars_dir, sun_near, moons))) == 0
    # A moon behind Mars (occulted), with a glare rule loose enough not to hide it by itself.
    behind = {"phobos": [1.0e5, 0.5 * R_MARS_EQ_KM, 0.0], "deimos": [0.0, sep_ok, 0.0]}
    out = _run(FakeScene(mars_dir, sun_away, behind), glare_factor=1.0, glare_margin_px=0.0, targets=("phobos",))
    assert len(out) == 0
    in_front = {"phobos": [-1.0e5, 3.0 * R_MARS_EQ_KM, 0.0], "deimos": [0.0, sep_ok, 0.0]}
    out = _run(FakeScene(mars_dir, sun_away, in_front), glare_factor=1.0, glare_margin_px=0.0, targets=("phobos",))
    assert len(out) == 10
    # Mars too close to fit its disc in the image.
    near = np.array([R_MARS_EQ_KM / math.sin(600.0 / F_PX), 0.0, 0.0])
    assert len(_run(FakeScene(near, sun_away, moons), targets=("mars",))) == 0


def test_noise_sigmas_follow_the_apparent_size():
    far = 1.0e6
    moons = {"phobos": [0.0, 9000.0, 0.0], "deimos": [0.0, 0.0, 23000.0]}
    out = _run(FakeScene([far, 0.0, 0.0], [-1.5e8, 0.0, 0.0], moons), pointing_control_mrad=0.0, attitude_from="fixed")
    att = F_PX * 5e-6
    d_px = 2 * math.asin(R_MARS_EQ_KM / far) * F_PX
    for name, sig in (("mars", max(0.25, 1e-3 * d_px)), ("phobos", 0.25), ("deimos", 0.25)):
        sel = out.target == name
        assert sel.any()
        np.testing.assert_allclose(out.sigma[sel], math.hypot(sig, att), rtol=1e-12)


def test_centroids_match_an_independent_recomputation(sim_run):
    run = sim_run
    eph = default_ephemeris()
    opt = run.optical
    beacon_rows = np.flatnonzero(np.isin(opt.target, BEACONS))
    assert beacon_rows.size > 0
    sel = np.concatenate((np.linspace(0, len(opt) - 1, 25).astype(int), beacon_rows[:: max(1, beacon_rows.size // 10)]))
    for i in sel:
        t = opt.t_rx[i]
        r_sc = eph.position("mars", t, "ssb") + run.trajectory.position(t)
        name = opt.target[i]

        def target(te):
            if name in BEACONS:  # the onboard catalogue: within a few hundred km of the truth's
                return eph.position("sun", te, "ssb") + beacon_state(name, te)[0]
            p = eph.position("mars", te, "ssb")
            return p if name == "mars" else p + moon_state(name, te)[0]

        tau = brentq(lambda x: np.linalg.norm(target(t - x) - r_sc) - C_KM_S * x, 1e-3, 3000.0, xtol=1e-13)
        d = target(t - tau) - r_sc
        d_cam = quat_to_dcm(opt.attitude_q[i]).T @ d
        ref = 512.5 + F_PX * d_cam[:2] / d_cam[2]
        np.testing.assert_allclose(opt.clean[i], ref, atol=0.1 if name in BEACONS else 2e-4)
        assert np.all((ref > 0.5) & (ref < 1024.5))


def test_optical_noise_has_the_reported_sigma(sim_run):
    opt = sim_run.optical
    z = opt.noise / opt.sigma  # measured - noise-free, attitude-knowledge error included
    n = z.size
    chi2 = float(np.sum(z * z))
    # chi-square with n dof: mean n, sd sqrt(2n); allow 4 sd.
    assert abs(chi2 - n) < 4 * math.sqrt(2 * n)
    assert abs(float(np.mean(z))) < 4 / math.sqrt(n)


class BeaconScene(FakeScene):
    """FakeScene plus one asteroid beacon fixed at ``beacon`` (barycentric)."""

    def __init__(self, mars, sun, beacon):
        super().__init__(mars, sun, {})
        self._beacon = np.asarray(beacon, float)

    def target(self, name):
        if name == "vesta":
            return lambda t: np.tile(self._beacon, (np.size(t), 1))
        return super().target(name)


def test_beacon_visibility_rules():
    au = 1.495978707e8
    mars = np.array([2.0e6, 0.0, 0.0])
    sun = np.array([-1.0, -0.3, 0.0]) * au  # behind the spacecraft: full phase for beacons ahead
    kw = dict(targets=(), beacons=("vesta",), beacon_interval_s=1800.0, first_beacon_offset_s=900.0)
    far_off = np.array([0.0, 1.5 * au, 0.3 * au])  # 80 deg from Mars, V ~ 6.6
    assert len(_run(BeaconScene(mars, sun, far_off), **kw)) == 10
    assert len(_run(BeaconScene(mars, sun, far_off), limit_mag=6.0, **kw)) == 0  # too faint
    near_mars = 1.5 * au * np.array([1.0, math.tan(math.radians(1.0)), 0.0])  # 1 deg from Mars
    assert len(_run(BeaconScene(mars, sun, near_mars), **kw)) == 0
    # Mars 10,000 km away is 20 deg in radius: a beacon 5 deg from its centre is behind the disc
    close = np.array([1.0e4, 0.0, 0.0])
    behind = 1.5 * au * np.array([1.0, math.tan(math.radians(5.0)), 0.0])
    assert len(_run(BeaconScene(close, sun, behind), beacon_mars_keepout_deg=2.0, **kw)) == 0
    # a beacon opposite the Sun's side at large phase: Sun beyond the beacon
    sun_behind_beacon = far_off * 3.0
    assert len(_run(BeaconScene(mars, sun_behind_beacon, far_off), sun_exclusion_deg=0.0, **kw)) == 0


def test_stacked_quaternions_equal_matrix_to_quat_bit_for_bit_on_every_branch():
    from fsw.astro.frames import matrix_to_quat, quat_to_matrix
    from sim.sensors.optical import _matrices_to_quats
    q = np.random.default_rng(1).standard_normal((4000, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    m = quat_to_matrix(q)
    diag = np.stack([np.trace(m, axis1=1, axis2=2), m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    assert set(np.argmax(diag, axis=1).tolist()) == {0, 1, 2, 3}
    assert np.array_equal(_matrices_to_quats(m), np.array([matrix_to_quat(x) for x in m]))
    assert _matrices_to_quats(np.zeros((0, 3, 3))).shape == (0, 4)

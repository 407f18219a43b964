"""Optical navigation images of Mars, Phobos and Deimos: centroids in pixels.

Per image slot (every ``image_interval_s``) the camera is pointed at one target, the targets
being taken in cyclic order; when the scheduled target is not visible, the next visible one in
the cycle is imaged, and if none is, no image is taken.

Geometry: the apparent target direction is the light-time-corrected one, d = r_tgt(t - tau) -
r_sc(t) with |d| = c tau (barycentric frame, :mod:`sim.sensors.lighttime`). Stellar aberration
is left out on purpose: the attitude comes from star trackers that see the same aberration, so
it cancels in the target-relative-to-stars measurement.

Attitude: the *commanded* pointing puts the boresight on the target, off by a pointing-control
error (``pointing_control_mrad`` per cross-boresight axis, so targets are not always centred).
The onboard attitude estimate equals the command and is what ``attitude_q`` reports
(camera -> ICRF, scalar first). The *true* camera attitude is C_true = C_known R(delta), with
delta ~ N(0, sigma_att^2 I) a rotation vector in camera axes (attitude-knowledge error).

Noise: the reported centroid is the pinhole projection (:mod:`sim.sensors.camera`) of d through
C_true plus centroid noise of sigma_c per axis, sigma_c = ``moon_sigma_px`` for the moons and
max(``mars_sigma_floor_px``, ``mars_sigma_fraction`` x apparent diameter [px]) for Mars. Seen
through the known attitude, the knowledge error adds f sigma_att (~0.21 px) per axis, i.i.d.
from image to image, so the reported sigma is sqrt(sigma_c^2 + (f sigma_att)^2) per axis.

Visibility rules (all must hold):
1. Sun: the boresight is at least ``sun_exclusion_deg`` from the Sun.
2. Image: the target centre lies ``edge_margin_px`` inside the detector; for Mars the whole
   disc (centre +- apparent radius) must, since its centre is found from the limb.
3. Occultation: a moon farther than Mars and within Mars' apparent radius is hidden.
4. Glare: a moon closer (in angle) to Mars' centre than ``glare_factor`` Mars apparent radii
   plus ``glare_margin_px`` is lost in Mars' glare (this includes transits across the disc).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import R_MARS_EQ_KM
from fsw.astro.frames import matrix_to_quat
from sim.sensors.camera import pointing_frame, project, small_rotation
from sim.sensors.config import OpticalConfig
from sim.sensors.geometry import Scene
from sim.sensors.lighttime import light_time


@dataclass(frozen=True)
class OpticalData:
    """Optical measurements kept after visibility (arrays of equal length, by image time).

    ``clean`` is the projection through the *known* attitude without centroid noise (what a
    perfect onboard model predicts from the true state); ``noise`` = measured - clean.
    """

    t_rx: np.ndarray  # (N,) TDB image times
    target: np.ndarray  # (N,) object
    clean: np.ndarray  # (N, 2) px
    noise: np.ndarray  # (N, 2) px
    sigma: np.ndarray  # (N, 2) px
    attitude_q: np.ndarray  # (N, 4) known camera -> ICRF, scalar first
    apparent_diameter_px: np.ndarray  # (N,)
    slot: np.ndarray  # (N,) image slot index

    def __len__(self) -> int:
        return int(self.t_rx.size)


def image_times(cfg: OpticalConfig, t_start: float, t_end: float) -> np.ndarray:
    """Image slot times: every ``image_interval_s`` from ``t_start + first_image_offset_s``."""
    first = t_start + cfg.first_image_offset_s
    if not cfg.enabled or first > t_end:
        return np.zeros(0)
    n = int(np.floor((t_end - first) / cfg.image_interval_s + 1e-9)) + 1
    return first + cfg.image_interval_s * np.arange(n)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def simulate_optical(
    cfg: OpticalConfig, scene: Scene, t_start: float, t_end: float, rng: np.random.Generator
) -> OpticalData:
    """Every optical measurement of the run (see the module docstring for the model).

    ``rng`` is this sensor's own stream: per slot it draws 2 pointing-control, 3
    attitude-knowledge and 2 centroid normals (as three blocks), whatever is visible.
    """
    t = image_times(cfg, t_start, t_end)
    n, nt = t.size, len(cfg.targets)
    z_ctrl = rng.standard_normal((n, 2))
    z_att = rng.standard_normal((n, 3))
    z_cen = rng.standard_normal((n, 2))
    if n == 0:
        return OpticalData(t, np.zeros(0, dtype=object), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2)),
                           np.zeros((0, 4)), np.zeros(0), np.zeros(0, dtype=np.int64))
    f_px = cfg.focal_px
    pp = (float(cfg.principal_point_px[0]), float(cfg.principal_point_px[1]))
    lo = 0.5 + cfg.edge_margin_px
    hi = cfg.pixels + 0.5 - cfg.edge_margin_px

    r_sc = scene.sc(t)
    sun_dir = _unit(scene.body("sun", t) - r_sc)
    ctrl = np.column_stack((cfg.pointing_control_mrad * 1e-3 * z_ctrl, np.zeros(n)))
    R_ctrl = small_rotation(ctrl)
    R_att = small_rotation(cfg.attitude_knowledge_urad * 1e-6 * z_att)

    _, pos_m = light_time(t, r_sc, scene.target("mars"), scene.target_velocity("mars"))
    d_mars = pos_m - r_sc
    rho_mars = np.arcsin(np.clip(R_MARS_EQ_KM / np.linalg.norm(d_mars, axis=1), 0.0, 1.0))

    clean = np.empty((nt, n, 2))
    meas = np.empty((nt, n, 2))
    known = np.empty((nt, n, 3, 3))
    visible = np.empty((nt, n), dtype=bool)
    diam_px = np.zeros((nt, n))
    for j, name in enumerate(cfg.targets):
        if name == "mars":
            d = d_mars
        else:
            _, pos = light_time(t, r_sc, scene.target(name), scene.target_velocity(name))
            d = pos - r_sc
        C_known = pointing_frame(d) @ R_ctrl
        C_true = C_known @ R_att
        known[j] = C_known
        clean[j] = project(d, C_known, f_px, pp)
        meas[j] = project(d, C_true, f_px, pp)
        ok = np.einsum("ij,ij->i", _unit(d), sun_dir) <= np.cos(np.radians(cfg.sun_exclusion_deg))
        if name == "mars":
            diam_px[j] = 2.0 * rho_mars * f_px
            half = 0.5 * diam_px[j]
            ok &= np.all((meas[j] - half[:, None] >= lo) & (meas[j] + half[:, None] <= hi), axis=1)
        else:
            ok &= np.all((meas[j] >= lo) & (meas[j] <= hi), axis=1)
            sep = np.arccos(np.clip(np.einsum("ij,ij->i", _unit(d), _unit(d_mars)), -1.0, 1.0))
            behind = np.linalg.norm(d, axis=1) > np.linalg.norm(d_mars, axis=1)
            ok &= ~(behind & (sep < rho_mars))
            ok &= sep >= cfg.glare_factor * rho_mars + cfg.glare_margin_px / f_px
        visible[j] = ok

    # Cyclic choice: slot k prefers target k mod nt, then the following ones.
    order = (np.arange(n)[:, None] + np.arange(nt)[None, :]) % nt  # (n, nt) target indices
    vis_in_order = visible.T[np.arange(n)[:, None], order]
    has = vis_in_order.any(axis=1)
    pick = order[np.arange(n), np.argmax(vis_in_order, axis=1)]
    slots = np.flatnonzero(has)
    j = pick[slots]

    names = np.array(cfg.targets, dtype=object)[j]
    dpx = diam_px[j, slots]
    sig_c = np.where(names == "mars", np.maximum(cfg.mars_sigma_floor_px, cfg.mars_sigma_fraction * dpx),
                     cfg.moon_sigma_px)
    sig_att_px = f_px * cfg.attitude_knowledge_urad * 1e-6
    sigma = np.sqrt(sig_c**2 + sig_att_px**2)[:, None] * np.ones((1, 2))
    clean_k = clean[j, slots]
    measured = meas[j, slots] + sig_c[:, None] * z_cen[slots]
    quats = np.array([matrix_to_quat(m) for m in known[j, slots]]).reshape(-1, 4)
    return OpticalData(
        t_rx=t[slots],
        target=names,
        clean=clean_k,
        noise=measured - clean_k,
        sigma=sigma,
        attitude_q=quats,
        apparent_diameter_px=dpx,
        slot=slots.astype(np.int64),
    )

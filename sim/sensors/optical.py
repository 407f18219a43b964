"""Optical navigation images of Mars, Phobos, Deimos and asteroid beacons: centroids in pixels.

Schedule. Two interleaved image series: every ``image_interval_s`` a Mars-system image, the
targets taken in cyclic order (when the scheduled one is not visible the next visible one in
the cycle is imaged, and if none is, no image is taken); and every ``beacon_interval_s`` an
image of an asteroid beacon (:mod:`sim.sensors.asteroids`), taking the visible beacons in turn
(the k-th beacon slot images visible beacon number k modulo their count). Lubey & Ely 2022 (§4.1) image Mars, Phobos, Deimos and "other optical targets
(i.e., asteroids)" following Ely et al. 2021; the cadences here are this simulator's choice.

Geometry: the apparent target direction is the light-time-corrected one, d = r_tgt(t - tau) -
r_sc(t) with |d| = c tau (barycentric frame, :mod:`sim.sensors.lighttime`). Stellar aberration
is left out on purpose: the attitude comes from stars that see the same aberration, so it
cancels in the target-relative-to-stars measurement.

Pointing profile. The spacecraft turns to put the boresight on each target, off by a
pointing-control error (``pointing_control_mrad`` per cross-boresight axis). Its roll about the
boresight (``roll``) is either ``sun``-keeping — the line axis (+y) points away from the Sun's
direction as far as the boresight allows (solar arrays towards the Sun), with a uniform error
within +- ``roll_deadband_deg`` —, uniformly ``random``, or fixed to ICRF ``north``. The camera
attitude therefore changes from image to image and from target to target.

Attitude knowledge (``attitude_from: stars``): the camera attitude is fitted to the catalogue
stars in the same image (as MRO's optical navigation camera and Deep Space 1's AutoNav do). The
number of stars brighter than the limiting magnitude m in the field of view is Poisson with
mean N_sky(m) Omega_fov / 4 pi, N_sky(m) = 6.57 exp(1.08 m) stars over the whole sky (Liebe
2002, "Accuracy performance of star trackers — a tutorial", IEEE TAES 38(2), eq. 2). Star
magnitudes follow the same law (m = m_lim + ln U / 1.08), positions are uniform over the
detector, and a star's centroid error grows with its faintness as photon noise does,
sigma_i = max(floor, sigma_lim 10^(0.2 (m_i - m_lim))). The least-squares attitude fit then has
cross-boresight error IFOV / sqrt(sum 1/sigma_i^2) per axis and roll error
1 / sqrt(sum rho_i^2 / sigma_i^2) (rho_i the star's distance from the principal point in px) —
Liebe's sigma IFOV / sqrt(N) and sigma / (0.38 N_pix sqrt(N)) for equal stars. An image with
fewer than ``min_stars`` stars gives no attitude and is not used. With ``attitude_from: fixed``
the knowledge error is ``attitude_knowledge_urad`` per axis instead.

The onboard attitude estimate C_known is what ``attitude_q`` reports (camera -> ICRF, scalar
first); the true attitude is C_true = C_known R(delta), delta ~ N(0, diag(s_cb^2, s_cb^2,
s_roll^2)) a rotation vector in camera axes.

Noise: the reported centroid is the pinhole projection (:mod:`sim.sensors.camera`) of d through
C_true plus centroid noise sigma_c per axis: ``moon_sigma_px`` for the moons; for beacons the
larger of that and the star law at the beacon's magnitude; max(``mars_sigma_floor_px``,
``mars_sigma_fraction`` x apparent diameter [px]) for Mars. Seen through the known attitude, the
knowledge error adds f s_cb per axis and the roll error s_roll times the lever arm (sample:
line offset from the principal point; line: sample offset), so the reported sigma is
sqrt(sigma_c^2 + (f s_cb)^2 + (s_roll lever)^2) per axis.

Visibility rules (all must hold):
1. Sun: the boresight is at least ``sun_exclusion_deg`` from the Sun.
2. Image: the target centre lies ``edge_margin_px`` inside the detector; for Mars the whole
   disc (centre +- apparent radius) must, since its centre is found from the limb.
3. Occultation: a moon farther than Mars and within Mars' apparent radius is hidden.
4. Glare: a moon closer (in angle) to Mars' centre than ``glare_factor`` Mars apparent radii
   plus ``glare_margin_px`` is lost in Mars' glare (this includes transits across the disc);
   a beacon within ``beacon_mars_keepout_deg`` of Mars (or within the moons' glare limit, when
   that is larger: behind or beside a near Mars' disc) is lost in its stray light.
5. Beacons: phase angle (Sun-beacon-spacecraft) at most ``max_phase_deg`` and V magnitude (H, G
   system) at most ``limit_mag``.
6. Stars: at least ``min_stars`` stars in the field (``attitude_from: stars``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsw.astro.constants import R_MARS_EQ_KM
from fsw.astro.frames import FrameError
from sim.sensors import asteroids
from sim.sensors.camera import pointing_frame, project, small_rotation
from sim.sensors.config import OpticalConfig
from sim.sensors.geometry import Scene
from sim.sensors.lighttime import light_time

#: Liebe 2002 eq. 2: stars brighter than m over the whole sky = LIEBE_A exp(LIEBE_B m).
LIEBE_A = 6.57
LIEBE_B = 1.08


@dataclass(frozen=True)
class OpticalData:
    """Optical measurements kept after visibility (arrays of equal length, by image time).

    ``clean`` is the projection through the *known* attitude without centroid noise (what a
    perfect onboard model predicts from the true state); ``noise`` = measured - clean.
    ``attitude_sigma`` is the star fit's knowledge 1-sigma [rad] about camera x, y (cross-
    boresight) and z (roll); ``stars`` the number of stars it used; ``roll`` the roll angle [rad]
    of the line axis from ICRF north about the boresight (for diagnostics).
    """

    t_rx: np.ndarray  # (N,) TDB image times
    target: np.ndarray  # (N,) object
    clean: np.ndarray  # (N, 2) px
    noise: np.ndarray  # (N, 2) px
    sigma: np.ndarray  # (N, 2) px
    attitude_q: np.ndarray  # (N, 4) known camera -> ICRF, scalar first
    apparent_diameter_px: np.ndarray  # (N,)
    slot: np.ndarray  # (N,) slot index: the Mars-system slots, then the beacon slots
    attitude_sigma: np.ndarray  # (N, 3) rad
    stars: np.ndarray  # (N,) stars in the fit (-1: attitude_from fixed)
    roll: np.ndarray  # (N,) rad

    def __len__(self) -> int:
        return int(self.t_rx.size)


def _times(enabled: bool, first: float, interval: float, t_end: float) -> np.ndarray:
    if not enabled or first > t_end:
        return np.zeros(0)
    n = int(np.floor((t_end - first) / interval + 1e-9)) + 1
    return first + interval * np.arange(n)


def image_times(cfg: OpticalConfig, t_start: float, t_end: float) -> np.ndarray:
    """Mars-system image slot times: every ``image_interval_s`` from ``t_start + first_image_offset_s``."""
    return _times(cfg.enabled and bool(cfg.targets), t_start + cfg.first_image_offset_s, cfg.image_interval_s, t_end)


def beacon_times(cfg: OpticalConfig, t_start: float, t_end: float) -> np.ndarray:
    """Beacon image slot times: every ``beacon_interval_s`` from ``t_start + first_beacon_offset_s``."""
    return _times(cfg.enabled and bool(cfg.beacons), t_start + cfg.first_beacon_offset_s, cfg.beacon_interval_s, t_end)


def mean_stars(cfg: OpticalConfig) -> float:
    """Expected number of stars brighter than ``limit_mag`` in the field of view (Liebe 2002)."""
    fov = cfg.pixels * cfg.pixel_pitch_um * 1e-3 / cfg.focal_length_mm  # rad, small-angle
    return LIEBE_A * float(np.exp(LIEBE_B * cfg.limit_mag)) * fov * fov / (4.0 * np.pi)


def point_sigma_px(cfg: OpticalConfig, mag: np.ndarray) -> np.ndarray:
    """Centroid 1-sigma [px] of a point source of V magnitude ``mag`` (photon-noise law)."""
    return np.maximum(cfg.star_sigma_floor_px, cfg.star_sigma_px * 10.0 ** (0.2 * (np.asarray(mag) - cfg.limit_mag)))


def star_fit(cfg: OpticalConfig, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per slot: number of stars (n,) and attitude-knowledge 1-sigma (n, 3) [rad] of the star fit.

    Draws n Poisson counts, then for all stars together magnitudes and positions (one block
    each), so the stream use depends only on the counts. Slots with fewer than two stars get
    infinite sigmas."""
    if cfg.attitude_from == "fixed":
        s = cfg.attitude_knowledge_urad * 1e-6
        return np.full(n, -1, dtype=np.int64), np.full((n, 3), s)
    counts = rng.poisson(mean_stars(cfg), n)
    total = int(counts.sum())
    mags = cfg.limit_mag + np.log(1.0 - rng.random(total)) / LIEBE_B
    pos = (rng.random((total, 2)) * cfg.pixels + 0.5) - np.asarray(cfg.principal_point_px, dtype=float)
    w = 1.0 / point_sigma_px(cfg, mags) ** 2
    owner = np.repeat(np.arange(n), counts)
    info_cb = np.bincount(owner, weights=w, minlength=n)
    info_roll = np.bincount(owner, weights=w * np.sum(pos * pos, axis=1), minlength=n)
    ifov = cfg.pixel_pitch_um * 1e-3 / cfg.focal_length_mm
    with np.errstate(divide="ignore"):
        s_cb = np.where(counts >= 2, ifov / np.sqrt(info_cb), np.inf)
        s_roll = np.where(counts >= 2, 1.0 / np.sqrt(info_roll), np.inf)
    return counts.astype(np.int64), np.column_stack((s_cb, s_cb, s_roll))


def _empty() -> OpticalData:
    e2 = np.zeros((0, 2))
    return OpticalData(np.zeros(0), np.zeros(0, dtype=object), e2, e2, e2, np.zeros((0, 4)), np.zeros(0),
                       np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros(0, dtype=np.int64), np.zeros(0))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _matrices_to_quats(m: np.ndarray) -> np.ndarray:
    """:func:`fsw.astro.frames.matrix_to_quat` of each matrix (N, 3, 3) -> (N, 4): the same
    Shepperd branches and arithmetic, element for element, on the whole stack at once."""
    if m.shape[0] == 0:
        return np.zeros((0, 4))
    if not np.all(np.isfinite(m)) or np.any(np.abs(np.linalg.det(m) - 1.0) > 1e-6):
        raise FrameError("not a proper rotation matrix")
    tr = np.trace(m, axis1=1, axis2=2)
    k = np.argmax(np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1), axis=1)
    q = np.empty((m.shape[0], 4))
    for branch in range(4):
        sel = k == branch
        if not sel.any():
            continue
        a, t = m[sel], tr[sel]
        d21, d02, d10 = a[:, 2, 1] - a[:, 1, 2], a[:, 0, 2] - a[:, 2, 0], a[:, 1, 0] - a[:, 0, 1]
        s01, s02, s12 = a[:, 0, 1] + a[:, 1, 0], a[:, 0, 2] + a[:, 2, 0], a[:, 1, 2] + a[:, 2, 1]
        if branch == 0:
            w = 0.5 * np.sqrt(1.0 + t)
            q[sel] = np.column_stack((w, d21 / (4 * w), d02 / (4 * w), d10 / (4 * w)))
        elif branch == 1:
            x = 0.5 * np.sqrt(1.0 + 2 * a[:, 0, 0] - t)
            q[sel] = np.column_stack((d21 / (4 * x), x, s01 / (4 * x), s02 / (4 * x)))
        elif branch == 2:
            y = 0.5 * np.sqrt(1.0 + 2 * a[:, 1, 1] - t)
            q[sel] = np.column_stack((d02 / (4 * y), s01 / (4 * y), y, (a[:, 1, 2] + a[:, 2, 1]) / (4 * y)))
        else:
            z = 0.5 * np.sqrt(1.0 + 2 * a[:, 2, 2] - t)
            q[sel] = np.column_stack((d10 / (4 * z), s02 / (4 * z), s12 / (4 * z), z))
    # the norm as np.linalg.norm takes it of one quaternion (a dot product of the row), row by row
    q /= np.sqrt(np.array([row.dot(row) for row in q]))[:, None]
    return np.where(q[:, :1] < 0, -q, q)


def simulate_optical(
    cfg: OpticalConfig, scene: Scene, t_start: float, t_end: float, rng: np.random.Generator
) -> OpticalData:
    """Every optical measurement of the run (see the module docstring for the model).

    ``rng`` is this sensor's own stream: for all slots (Mars-system then beacon, each in time
    order) it draws, as blocks, 2 pointing-control, 1 roll, 3 attitude-knowledge and 2 centroid
    normals per slot, then the star fields (:func:`star_fit`), whatever is visible.
    """
    t_sys = image_times(cfg, t_start, t_end)
    t_bcn = beacon_times(cfg, t_start, t_end)
    t = np.concatenate((t_sys, t_bcn))
    n = t.size
    is_beacon = np.arange(n) >= t_sys.size
    z_ctrl = rng.standard_normal((n, 2))
    u_roll = rng.random(n)
    z_att = rng.standard_normal((n, 3))
    z_cen = rng.standard_normal((n, 2))
    stars, att_sigma = star_fit(cfg, rng, n)
    if n == 0:
        return _empty()
    f_px = cfg.focal_px
    pp = (float(cfg.principal_point_px[0]), float(cfg.principal_point_px[1]))
    lo = 0.5 + cfg.edge_margin_px
    hi = cfg.pixels + 0.5 - cfg.edge_margin_px
    star_ok = np.ones(n, dtype=bool) if cfg.attitude_from == "fixed" else stars >= cfg.min_stars

    r_sc = scene.sc(t)
    r_sun = scene.body("sun", t)
    sun_dir = _unit(r_sun - r_sc)
    R_ctrl = small_rotation(np.column_stack((cfg.pointing_control_mrad * 1e-3 * z_ctrl, np.zeros(n))))
    if cfg.roll == "random":
        phi = 2.0 * np.pi * u_roll
    elif cfg.roll == "sun":
        phi = np.radians(cfg.roll_deadband_deg) * (2.0 * u_roll - 1.0)
    else:
        phi = np.zeros(n)
    R_roll = small_rotation(np.column_stack((np.zeros((n, 2)), phi)))
    ref = -sun_dir if cfg.roll == "sun" else None
    delta = np.where(np.isfinite(att_sigma), att_sigma, 0.0) * z_att
    R_att = small_rotation(delta)

    _, pos_m = light_time(t, r_sc, scene.target("mars"), scene.target_velocity("mars"))
    d_mars = pos_m - r_sc
    rho_mars = np.arcsin(np.clip(R_MARS_EQ_KM / np.linalg.norm(d_mars, axis=1), 0.0, 1.0))

    beacon_names = tuple(cfg.beacons)
    groups = ((tuple(cfg.targets), np.flatnonzero(~is_beacon)), (beacon_names, np.flatnonzero(is_beacon)))
    names_out: list[np.ndarray] = []
    rows: list[np.ndarray] = []
    results: list[dict[str, np.ndarray]] = []
    for names, slots in groups:
        nt, ns = len(names), slots.size
        if nt == 0 or ns == 0:
            continue
        res = {k: np.zeros((nt, ns) + shape) for k, shape in
               (("clean", (2,)), ("meas", (2,)), ("known", (3, 3)), ("diam", ()), ("mag", ()), ("roll", ()))}
        visible = np.zeros((nt, ns), dtype=bool)
        ts, rs = t[slots], r_sc[slots]
        for j, name in enumerate(names):
            if name == "mars":
                d = d_mars[slots]
                pos = pos_m[slots]
            else:
                _, pos = light_time(ts, rs, scene.target(name), scene.target_velocity(name))
                d = pos - rs
            C0 = pointing_frame(d, None if ref is None else ref[slots])
            C_known = C0 @ R_roll[slots] @ R_ctrl[slots]
            C_true = C_known @ R_att[slots]
            res["known"][j] = C_known
            res["clean"][j] = project(d, C_known, f_px, pp)
            res["meas"][j] = meas = project(d, C_true, f_px, pp)
            north = np.array([0.0, 0.0, 1.0]) - C_known[:, :, 2] * C_known[:, 2, 2][:, None]
            res["roll"][j] = np.arctan2(np.einsum("ij,ij->i", north, C_known[:, :, 0]),
                                        np.einsum("ij,ij->i", north, C_known[:, :, 1]))
            u = _unit(d)
            ok = star_ok[slots] & (np.einsum("ij,ij->i", u, sun_dir[slots]) <= np.cos(np.radians(cfg.sun_exclusion_deg)))
            sep = np.arccos(np.clip(np.einsum("ij,ij->i", u, _unit(d_mars[slots])), -1.0, 1.0))
            if name == "mars":
                res["diam"][j] = 2.0 * rho_mars[slots] * f_px
                half = 0.5 * res["diam"][j]
                ok &= np.all((meas - half[:, None] >= lo) & (meas + half[:, None] <= hi), axis=1)
            elif name in asteroids.BY_NAME:
                ok &= np.all((meas >= lo) & (meas <= hi), axis=1)
                # near Mars the disc itself (and its glare) is larger than the keep-out cone
                ok &= sep >= np.maximum(np.radians(cfg.beacon_mars_keepout_deg),
                                        cfg.glare_factor * rho_mars[slots] + cfg.glare_margin_px / f_px)
                to_sun = r_sun[slots] - pos  # light left the beacon at t - tau; the Sun barely moves
                phase = np.arccos(np.clip(np.einsum("ij,ij->i", _unit(to_sun), -u), -1.0, 1.0))
                mag = asteroids.apparent_magnitude(name, np.linalg.norm(to_sun, axis=1), np.linalg.norm(d, axis=1), phase)
                res["mag"][j] = mag
                ok &= (phase <= np.radians(cfg.max_phase_deg)) & (mag <= cfg.limit_mag)
            else:
                ok &= np.all((meas >= lo) & (meas <= hi), axis=1)
                behind = np.linalg.norm(d, axis=1) > np.linalg.norm(d_mars[slots], axis=1)
                ok &= ~(behind & (sep < rho_mars[slots]))
                ok &= sep >= cfg.glare_factor * rho_mars[slots] + cfg.glare_margin_px / f_px
            visible[j] = ok
        if names is beacon_names:
            # Round robin over the visible beacons: the k-th slot takes visible beacon k mod (count).
            count = visible.sum(axis=0)
            has = count > 0
            rank = np.arange(ns) % np.maximum(count, 1)
            pick = np.argmax(np.cumsum(visible, axis=0) > rank[None, :], axis=0)
        else:
            # Cyclic choice: the k-th slot of the series prefers target k mod nt, then the following ones.
            order = (np.arange(ns)[:, None] + np.arange(nt)[None, :]) % nt
            vis_in_order = visible.T[np.arange(ns)[:, None], order]
            has = vis_in_order.any(axis=1)
            pick = order[np.arange(ns), np.argmax(vis_in_order, axis=1)]
        k = np.flatnonzero(has)
        names_out.append(np.array(names, dtype=object)[pick[k]])
        rows.append(slots[k])
        results.append({key: v[pick[k], k] for key, v in res.items()})

    if not rows:
        return _empty()
    slot = np.concatenate(rows)
    target = np.concatenate(names_out)
    cat = {key: np.concatenate([r[key] for r in results]) for key in results[0]}
    by_time = np.argsort(t[slot], kind="stable")
    slot, target = slot[by_time], target[by_time]
    cat = {key: v[by_time] for key, v in cat.items()}

    dpx = cat["diam"]
    is_mars = target == "mars"
    is_bcn = np.array([str(v) in asteroids.BY_NAME for v in target], dtype=bool)
    sig_c = np.where(is_mars, np.maximum(cfg.mars_sigma_floor_px, cfg.mars_sigma_fraction * dpx), cfg.moon_sigma_px)
    sig_c = np.where(is_bcn, np.maximum(cfg.moon_sigma_px, point_sigma_px(cfg, cat["mag"])), sig_c)
    s = att_sigma[slot]
    off = cat["clean"] - np.array(pp)
    sig_sample = np.sqrt(sig_c**2 + (f_px * s[:, 1]) ** 2 + (s[:, 2] * off[:, 1]) ** 2)
    sig_line = np.sqrt(sig_c**2 + (f_px * s[:, 0]) ** 2 + (s[:, 2] * off[:, 0]) ** 2)
    measured = cat["meas"] + sig_c[:, None] * z_cen[slot]
    quats = _matrices_to_quats(np.asarray(cat["known"], dtype=float).reshape(-1, 3, 3))
    return OpticalData(
        t_rx=t[slot],
        target=target,
        clean=cat["clean"],
        noise=measured - cat["clean"],
        sigma=np.column_stack((sig_sample, sig_line)),
        attitude_q=quats,
        apparent_diameter_px=dpx,
        slot=slot.astype(np.int64),
        attitude_sigma=s,
        stars=stars[slot],
        roll=cat["roll"],
    )

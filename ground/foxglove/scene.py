"""The 3-D scene of a run in metres: Mars and its moons, truth and estimated trajectories, the
covariance ellipsoid of the combined estimate, the direction of the Earth.

Frames: ``mars`` (Mars-centred ICRF, the fixed frame) and ``spacecraft`` (the true spacecraft
position, a ``foxglove.FrameTransform`` per truth sample). Trajectories are drawn as line
segments appended per scene update (entity ids ``truth-path/<n>``), so each update carries only
the new points and the file stays small.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
from foxglove import messages as fm

from fsw.astro.constants import R_MARS_EQ_KM
from fsw.astro.moons import moon_state
from ground.foxglove.records import ChannelSchema, FoxgloveRecord, well_known

SCENE_TOPIC = "/foxglove/scene"
TRANSFORM_TOPIC = "/foxglove/transforms"
FIXED_FRAME = "mars"
SPACECRAFT_FRAME = "spacecraft"
SCENE_SCHEMA: ChannelSchema = well_known(fm.SceneUpdate)
TRANSFORM_SCHEMA: ChannelSchema = well_known(fm.FrameTransform)

M_PER_KM = 1000.0
_MOON_MARKER_KM = 400.0  # Phobos (11 km) and Deimos (6 km) would be invisible at approach scale
_EARTH_ARROW_KM = 30000.0
_SPACECRAFT_MARKER_KM = 300.0


def _color(r: float, g: float, b: float, a: float = 1.0) -> fm.Color:
    return fm.Color(r=r, g=g, b=b, a=a)


TRUTH_COLOR = _color(0.2, 0.8, 0.2)
ESTIMATE_COLOR = _color(0.3, 0.5, 1.0)


def _ts(ns: int) -> fm.Timestamp:
    return fm.Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)


def _pose(p_km: Any, q: fm.Quaternion | None = None) -> fm.Pose:
    x, y, z = (float(v) * M_PER_KM for v in p_km)
    return fm.Pose(position=fm.Vector3(x=x, y=y, z=z), orientation=q or fm.Quaternion(w=1.0))


def quaternion_of(rot: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (x, y, z, w) of a proper rotation matrix (Shepperd's method)."""
    m = rot
    tr = float(np.trace(m))
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        w, x, y, z = 0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = np.empty(3)
        q[i] = 0.25 * s
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
        w = (m[k, j] - m[j, k]) / s
        x, y, z = q
    return float(x), float(y), float(z), float(w)


def _quat(xyzw: tuple[float, float, float, float]) -> fm.Quaternion:
    return fm.Quaternion(x=xyzw[0], y=xyzw[1], z=xyzw[2], w=xyzw[3])


def ellipsoid(cov_km2: np.ndarray, n_sigma: float = 3.0) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """Diameters [km] along the principal axes and the orientation of the ``n_sigma`` ellipsoid."""
    vals, vecs = np.linalg.eigh(0.5 * (cov_km2 + cov_km2.T))
    if np.linalg.det(vecs) < 0:
        vecs[:, 2] = -vecs[:, 2]
    return 2.0 * n_sigma * np.sqrt(np.maximum(vals, 0.0)), quaternion_of(vecs)


#: span of each table of Earth's position the scene interpolates (a 45-day run makes five)
_EARTH_TABLE_S = 10 * 86400.0


@lru_cache(maxsize=1)
def _ephemeris() -> Any:
    from fsw.astro.ephemeris import default_ephemeris

    return default_ephemeris()


class SceneBuilder:
    """Turns recorded truth and estimates (ICD messages as JSON dicts) into scene messages."""

    def __init__(self, every_s: float = 3600.0, path_step_s: float = 1800.0, estimate: str = "combined"):
        self.every_s = every_s
        self.path_step_s = path_step_s
        self.estimate = estimate
        self._next_scene: float | None = None
        self._truth_path: list[tuple[float, ...]] = []
        self._est_path: list[tuple[float, ...]] = []
        self._last_truth_pt: float | None = None
        self._truth: tuple[float, ...] | None = None
        self._segment = 0
        self._earth_table: Any = None  # EphemerisTable of Earth from Mars, made when first needed

    def truth(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        pos = tuple(float(v) for v in msg["position_km"])
        t = float(msg["t_s"])
        self._truth = pos
        if self._last_truth_pt is None or t - self._last_truth_pt >= self.path_step_s:
            self._truth_path.append(pos)
            self._last_truth_pt = t
        x, y, z = (v * M_PER_KM for v in pos)
        tf = fm.FrameTransform(timestamp=_ts(log_ns), parent_frame_id=FIXED_FRAME, child_frame_id=SPACECRAFT_FRAME,
                               translation=fm.Vector3(x=x, y=y, z=z), rotation=fm.Quaternion(w=1.0))
        return [FoxgloveRecord(TRANSFORM_TOPIC, TRANSFORM_SCHEMA, tf.encode(), log_ns)]

    def estimate_message(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        if msg.get("filter") != self.estimate:
            return []
        t = float(msg["t_s"])
        pos = tuple(float(v) for v in msg["position_km"])
        self._est_path.append(pos)
        if self._next_scene is not None and t < self._next_scene:
            return []
        first = self._next_scene is None
        self._next_scene = t + self.every_s
        entities = self._static(t, log_ns) if first else self._moving(t, log_ns)
        entities += self._paths(log_ns) + [self._ellipsoid(msg, pos, log_ns)]
        if first:
            entities += self._moving(t, log_ns)
        update = fm.SceneUpdate(entities=entities)
        return [FoxgloveRecord(SCENE_TOPIC, SCENE_SCHEMA, update.encode(), log_ns)]

    # -- entities ------------------------------------------------------------------------------
    def _entity(self, ident: str, log_ns: int, frame: str = FIXED_FRAME, **prims: Any) -> fm.SceneEntity:
        return fm.SceneEntity(timestamp=_ts(log_ns), frame_id=frame, id=ident, frame_locked=frame != FIXED_FRAME,
                              **prims)

    def _label(self, text: str, p_km: Any) -> fm.TextPrimitive:
        return fm.TextPrimitive(pose=_pose(p_km), billboard=True, font_size=14.0, scale_invariant=True,
                                color=_color(1, 1, 1), text=text)

    def _static(self, t: float, log_ns: int) -> list[fm.SceneEntity]:
        d = 2.0 * R_MARS_EQ_KM * M_PER_KM
        mars = fm.SpherePrimitive(pose=_pose((0, 0, 0)), size=fm.Vector3(x=d, y=d, z=d), color=_color(0.8, 0.35, 0.2))
        sc = _SPACECRAFT_MARKER_KM * M_PER_KM
        craft = fm.SpherePrimitive(pose=_pose((0, 0, 0)), size=fm.Vector3(x=sc, y=sc, z=sc), color=TRUTH_COLOR)
        return [self._entity("mars", log_ns, spheres=[mars], texts=[self._label("Mars", (0, 0, R_MARS_EQ_KM * 1.3))]),
                self._entity("spacecraft", log_ns, frame=SPACECRAFT_FRAME, spheres=[craft],
                             texts=[self._label("spacecraft (truth)", (0, 0, 0))])]

    def _moving(self, t: float, log_ns: int) -> list[fm.SceneEntity]:
        out = []
        size = 2.0 * _MOON_MARKER_KM * M_PER_KM
        for name in ("phobos", "deimos"):
            p, _ = moon_state(name, t)
            sphere = fm.SpherePrimitive(pose=_pose(p), size=fm.Vector3(x=size, y=size, z=size), color=_color(0.7, 0.7, 0.65))
            out.append(self._entity(name, log_ns, spheres=[sphere], texts=[self._label(name.capitalize(), p)],
                                    metadata=[fm.KeyValuePair(key="size", value="marker, not to scale")]))
        earth = self._earth_from_mars(t)
        u = earth / np.linalg.norm(earth)
        # the arrow points along +x of its pose: rotate +x onto the Earth direction
        axis = np.array([0.0, -u[2], u[1]])  # x̂ × u, written out (np.cross costs more than the scene's maths)
        s, c = float(np.linalg.norm(axis)), float(u[0])
        if s < 1e-12:
            q = fm.Quaternion(w=1.0) if c > 0 else fm.Quaternion(z=1.0)
        else:
            half = np.arctan2(s, c) / 2.0
            ax = axis / s * np.sin(half)
            q = fm.Quaternion(x=float(ax[0]), y=float(ax[1]), z=float(ax[2]), w=float(np.cos(half)))
        length = _EARTH_ARROW_KM * M_PER_KM
        arrow = fm.ArrowPrimitive(pose=_pose((0, 0, 0), q), shaft_length=0.85 * length, shaft_diameter=300e3,
                                  head_length=0.15 * length, head_diameter=1500e3, color=_color(0.3, 0.6, 1.0))
        out.append(self._entity("earth-direction", log_ns, arrows=[arrow],
                                texts=[self._label("to Earth", u * _EARTH_ARROW_KM * 1.05)]))
        return out

    def _earth_from_mars(self, t: float) -> np.ndarray:
        """Earth's position from Mars at t (km), from an interpolating table of DE421 over the days
        ahead (its error is below the positions' rounding): evaluated directly, DE421 cost ~0.2 ms
        a scene, a fifth of the logger's scene CPU."""
        tab = self._earth_table
        if tab is None or not tab.t_first <= t <= tab.t_last:
            tab = self._earth_table = _ephemeris().table(t, t + _EARTH_TABLE_S, bodies=("earth",), center="mars")
        return tab.positions(t)[0]

    def _paths(self, log_ns: int) -> list[fm.SceneEntity]:
        out = []
        for name, pts, color in (("truth-path", self._truth_path, TRUTH_COLOR), ("estimate-path", self._est_path, ESTIMATE_COLOR)):
            if len(pts) < 2:
                continue
            line = fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineStrip, pose=_pose((0, 0, 0)), thickness=2.0,
                                    scale_invariant=True, color=color,
                                    points=[fm.Point3(x=p[0] * M_PER_KM, y=p[1] * M_PER_KM, z=p[2] * M_PER_KM) for p in pts])
            out.append(self._entity(f"{name}/{self._segment}", log_ns, lines=[line]))
            del pts[:-1]  # the next segment starts where this one ends
        self._segment += 1
        return out

    def _ellipsoid(self, msg: dict[str, Any], pos: tuple[float, ...], log_ns: int) -> fm.SceneEntity:
        cov = msg.get("covariance")
        if cov:
            p3 = np.asarray(cov, dtype=float)[0:3, 0:3]
        else:
            p3 = np.diag(np.asarray(msg["sigma"][0:3], dtype=float) ** 2)
        size_km, q = ellipsoid(p3)
        size = [max(float(v), 1e-3) * M_PER_KM for v in size_km]
        sphere = fm.SpherePrimitive(pose=_pose(pos, _quat(q)), size=fm.Vector3(x=size[0], y=size[1], z=size[2]),
                                    color=_color(0.3, 0.5, 1.0, 0.4))
        return self._entity(f"estimate/{self.estimate}", log_ns, spheres=[sphere],
                            metadata=[fm.KeyValuePair(key="ellipsoid", value="3-sigma position")])

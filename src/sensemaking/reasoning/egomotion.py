"""Motion in the world, not in the image: distances in metres, the ego vehicle's own speed, and
every tracked object's speed over the road.

A box seen from a moving car moves in the image because the object moves *and* because the
camera does: a parked car passed at 30 km/h grows and slides sideways just as a car cutting in
does, and a car ahead driving at the ego's speed stands still in the image. The situations
mean what a driver means (stopped, approaching, overtaking, braking) only in the world. This
module gives them the numbers:

1. **Where**: a pinhole camera at ``height_m`` above a flat road (:class:`CameraModel`): the
   bottom edge of a box stands on the road, so its image row gives the distance ahead
   ``Z = focal * height / (row - horizon)`` and its column the lateral offset
   ``X = (column - cx) * Z / focal`` (metres, X positive to the right). Where the detector
   gives a 3D position (KITTI PointRCNN rows carry camera coordinates x, y, z), that is used.
2. **Relative velocity** of each track: the least-squares slope of Z and X over the last
   ``fit_s`` seconds, with its standard error (from the distance error that ``pixel_sd``
   pixels of box jitter make at that range).
3. **Ego speed** (:class:`EgoEstimator`): objects that stand still in the world all approach
   the camera at the ego's speed, so the dominant mode of ``-dZ/dt`` over the tracked objects
   is the ego speed (parked cars, signs, waiting cars are common); the mode kept from frame to
   frame is the one the ego can reach with at most ``max_accel_mps2``. The yaw rate follows
   from the lateral drift of the same static objects (``dX/dt = yaw_rate * Z``). An ego-motion
   file (:mod:`sensemaking.io.egomotion`) replaces the estimate where it has the frame.
4. **World velocity** of a track: relative velocity plus the ego's own motion,
   ``v_long = dZ/dt + v_ego + yaw_rate * X`` (positive: driving the ego's way, negative:
   oncoming) and ``v_lat = dX/dt - yaw_rate * Z``; its speed and standard error; the closing
   speed ``-dZ/dt`` and the time to contact ``Z / closing``.

What cannot be known is left out rather than guessed: no distance for a box whose bottom is at
the image's bottom edge (cut off: the road contact is not seen) or too near the horizon
(farther than ``max_range_m``), no ego speed before two static objects agree (or a file says
it), none after ``hold_s`` without static objects. Limits: a flat road and a level camera
(or, with ``horizon_from_scene``, one pitch per frame fitted to the boxes:
:class:`HorizonEstimator`); a scene with no static object in view (a queue of cars moving
together, and nothing else) makes the moving ones look static -- give the ego-motion file there.

:func:`world_facts` writes the numbers as the facts situations.lp reads (centimetres,
centimetres per second, integers); the rules that say what "stopped" or "sudden stop" means
are in situations.lp.
"""

from __future__ import annotations

import math
import weakref
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from sensemaking.classes import CLASS_IDS
from sensemaking.errors import InputError
from sensemaking.io.egomotion import EgoMotion

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.scene import Scene

__all__ = [
    "CameraModel",
    "EgoMotionConfig",
    "EgoState",
    "TrackMotion",
    "EgoEstimator",
    "HorizonEstimator",
    "OBJECT_HEIGHT_M",
    "fit_horizon",
    "WorldMotion",
    "estimate_ego_speed",
    "world_facts",
    "scene_world_motion",
    "world_story",
]


@dataclass(frozen=True)
class CameraModel:
    """A level pinhole camera at ``height_m`` above a flat road.

    Attributes:
        focal_px: focal length, pixels (KITTI's left colour camera: 721.5).
        cx_px: principal point column, pixels (KITTI: 609.6).
        horizon_px: image row of the horizon, pixels; for a level camera the principal point
            row (KITTI: 172.9).
        height_m: height of the camera above the road, metres (KITTI: 1.65).
        max_range_m: farthest distance given, metres: beyond it one pixel of box jitter moves
            the ground-plane distance by metres (at 50 m on KITTI: 2 m per pixel).
    """

    focal_px: float = 721.5
    cx_px: float = 609.6
    horizon_px: float = 172.9
    height_m: float = 1.65
    max_range_m: float = 50.0

    def __post_init__(self) -> None:
        for name in ("focal_px", "height_m", "max_range_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"camera {name} must be finite and > 0, got {v!r}")
        for name in ("cx_px", "horizon_px"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"camera {name} must be finite")

    @classmethod
    def kitti(cls) -> CameraModel:
        """KITTI's left colour camera (calibration of the tracking sequences, 1242x375)."""
        return cls()

    @classmethod
    def parse(cls, text: str) -> CameraModel:
        """From ``"focal_px,height_m,horizon_px,cx_px"`` (numbers). Raises InputError."""
        parts = [p for p in text.replace(" ", "").split(",") if p]
        try:
            nums = [float(p) for p in parts]
        except ValueError:
            raise InputError(
                f"camera must be focal_px,height_m,horizon_px,cx_px: {text!r}"
            ) from None
        if len(nums) != 4:
            raise InputError(
                f"camera needs 4 numbers focal_px,height_m,horizon_px,cx_px: {text!r}"
            )
        try:
            return cls(focal_px=nums[0], height_m=nums[1], horizon_px=nums[2], cx_px=nums[3])
        except ValueError as exc:
            raise InputError(str(exc)) from None

    def to_json(self) -> dict[str, float]:
        return {
            "focal_px": self.focal_px,
            "cx_px": self.cx_px,
            "horizon_px": self.horizon_px,
            "height_m": self.height_m,
            "max_range_m": self.max_range_m,
        }

    @classmethod
    def from_json(cls, record: Any) -> CameraModel:
        """From :meth:`to_json`'s object. Raises InputError for anything else."""
        if not isinstance(record, dict):
            raise InputError(f"a camera must be a JSON object, got {record!r}")
        try:
            return cls(**{k: float(v) for k, v in record.items()})
        except (TypeError, ValueError) as exc:
            raise InputError(f"bad camera {record!r}: {exc}") from None

    def ground_position(
        self, xyxy: np.ndarray, image_height: int | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Distance ahead Z and lateral offset X (N,) metres of boxes ``xyxy`` (N, 4) pixels
        standing on the road (bottom edge centre); NaN where unknown: the bottom at or above
        the horizon, beyond ``max_range_m``, or cut by the image's bottom edge."""
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        rows = b[:, 3] - self.horizon_px
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(rows > 0, self.focal_px * self.height_m / rows, np.nan)
        z = np.where(z <= self.max_range_m, z, np.nan)
        if image_height is not None:
            z = np.where(b[:, 3] >= image_height - 1.0, np.nan, z)
        x = ((b[:, 0] + b[:, 2]) / 2.0 - self.cx_px) * z / self.focal_px
        return z, x

    def distance_sd(self, z: np.ndarray, pixel_sd: float) -> np.ndarray:
        """Standard error (m) of a ground-plane distance ``z`` (m) for ``pixel_sd`` px of error
        in the bottom row: ``dZ/drow = Z^2 / (focal * height)``."""
        return np.asarray(z, dtype=np.float64) ** 2 / (self.focal_px * self.height_m) * pixel_sd


@dataclass(frozen=True)
class EgoMotionConfig:
    """Parameters of the ego-speed estimate and the track velocities (physical meaning, fixed
    before any measurement; docs/EGOMOTION.md).

    Attributes:
        fit_s: seconds of positions a velocity is fitted over (at least 3 positions spanning
            ``min_span_s``).
        min_span_s: shortest time span a velocity is fitted over, seconds.
        pixel_sd: error of a detector's box bottom edge, pixels (one standard deviation).
        location_sd_m: error of a detector's 3D position, metres (LiDAR: a few decimetres).
        bandwidth_mps: kernel width of the static-object mode, m/s (about half the speed of a
            walking person: a pedestrian does not pass for a parked car).
        min_static: objects that must agree on a first ego-speed estimate.
        max_accel_mps2: the most the ego speed changes per second (hard braking), m/s^2; the
            estimate follows the mode reachable with it.
        hold_s: seconds the last estimate is kept while no static object is in view.
        max_speed_mps: fastest ego speed considered, m/s.
        static_range_m: objects up to this distance vote on the ego speed, metres.
        max_vote_sd_mps: objects whose velocity is known worse than this (standard error),
            m/s, do not vote: they cannot tell a parked car from a walking person (three
            kernel widths).
        ego_lane_half_m: objects within this lateral offset (half a 3.5 m lane), metres, do
            not vote: the vehicle ahead in the ego's lane is the one the ego follows, and the
            one whose motion is to be judged.
        detection_location: take the position of a track from its matched detection's 3D
            ``location`` (a 3D detector's, carried by the tracker's output as
            ``detection_location``) instead of the box on a flat road. Off by default: on
            PointRCNN 0000-0010 it did not pass the keep rule (docs/DESIGN-NOTES.md, issue 22).
        horizon_from_scene: estimate the horizon row (the camera's pitch over the road) from
            the boxes instead of taking the camera model's ``horizon_px`` (a level camera):
            :class:`HorizonEstimator`. Off by default (docs/DESIGN-NOTES.md, "Camera pitch").
        horizon_window_s: seconds of boxes one horizon fit uses, > 0.
        horizon_smooth_s: time constant of the horizon's exponential smoothing, seconds, > 0;
            with too few boxes the estimate relaxes back to level at the same rate.
        horizon_min_boxes: boxes (in the window) a fit needs, >= 2.
        horizon_max_pitch_deg: the largest pitch the fit may give, degrees (0 < x < 45); the
            horizon stays within ``focal * tan`` of it from the level row.
        horizon_height_band: how far (relative, 0 <= x < 1) the fitted slope may stray from the
            camera height: 0 takes the camera height as the slope (only the horizon is fitted).
    """

    fit_s: float = 1.0
    min_span_s: float = 0.3
    pixel_sd: float = 1.5
    location_sd_m: float = 0.3
    bandwidth_mps: float = 0.7
    min_static: int = 2
    max_accel_mps2: float = 5.0
    hold_s: float = 2.0
    max_speed_mps: float = 45.0
    static_range_m: float = 40.0
    ego_lane_half_m: float = 1.75
    max_vote_sd_mps: float = 2.1
    detection_location: bool = False
    horizon_from_scene: bool = False
    horizon_window_s: float = 1.0
    horizon_smooth_s: float = 0.15
    horizon_min_boxes: int = 8
    horizon_max_pitch_deg: float = 3.0
    horizon_height_band: float = 0.1

    def __post_init__(self) -> None:
        for name in (
            "fit_s",
            "min_span_s",
            "pixel_sd",
            "location_sd_m",
            "bandwidth_mps",
            "max_accel_mps2",
            "max_speed_mps",
            "static_range_m",
            "ego_lane_half_m",
            "max_vote_sd_mps",
            "horizon_window_s",
            "horizon_smooth_s",
            "horizon_max_pitch_deg",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
        if self.hold_s < 0 or self.min_static < 1:
            raise ValueError("hold_s must be >= 0 and min_static >= 1")
        if self.horizon_min_boxes < 2 or not 0 <= self.horizon_height_band < 1:
            raise ValueError("horizon_min_boxes must be >= 2 and horizon_height_band in [0, 1)")
        if self.horizon_max_pitch_deg >= 45:
            raise ValueError("horizon_max_pitch_deg must be below 45")


@dataclass(frozen=True)
class EgoState:
    """The ego vehicle's motion at a frame.

    Attributes:
        speed: forward speed, m/s. sd: its standard error, m/s.
        yaw_rate: rad/s, positive turning left.
        support: static objects that agree with it (0 for a file or a held estimate).
        source: ``"file"``, ``"scene"`` or ``"held"`` (the last scene estimate, kept).
    """

    speed: float
    sd: float
    yaw_rate: float = 0.0
    support: int = 0
    source: str = "scene"


@dataclass(frozen=True)
class TrackMotion:
    """One visible track's place and motion at a frame (metres, m/s; NaN where unknown).

    ``z``/``x``: distance ahead and lateral offset (+ right); ``z_sd``: the standard error of
    ``z``; ``vz``/``vx``: relative velocity
    (vz < 0: coming closer); ``v_long``/``v_lat``: velocity over the road (v_long > 0: driving
    the ego's way); ``speed``/``speed_sd``: world speed and its standard error.
    """

    z: float
    x: float
    z_sd: float = math.nan
    vz: float = math.nan
    vx: float = math.nan
    v_sd: float = math.nan
    v_long: float = math.nan
    v_lat: float = math.nan
    speed: float = math.nan
    speed_sd: float = math.nan

    @property
    def closing(self) -> float:
        """Closing speed, m/s (> 0: the gap shrinks)."""
        return -self.vz

    @property
    def ttc_s(self) -> float:
        """Time to contact at the current closing speed, seconds (inf when not closing)."""
        c = self.closing
        return self.z / c if c > 0 else math.inf


def estimate_ego_speed(
    candidates: np.ndarray,
    sds: np.ndarray,
    bandwidth: float,
    max_speed: float,
    prior: float | None = None,
    reach: float = math.inf,
    min_support: int = 2,
) -> tuple[float, float, int] | None:
    """The ego speed (m/s), its standard error and support from the static-object hypothesis.

    Args:
        candidates: (N,) ``-dZ/dt`` of tracked objects, m/s: the ego speed if the object is
            static.
        sds: (N,) their standard errors, m/s.
        bandwidth: kernel width, m/s.
        max_speed: the highest speed considered, m/s.
        prior: the ego speed expected now (the last estimate), or None.
        reach: how far from ``prior`` the speed can be now, m/s.
        min_support: objects that must agree without a prior (with a prior: one).

    Returns None when no mode has enough support. Modes are maxima of a kernel density (each
    object weighs by its precision); among those within ``reach`` of ``prior`` the densest
    wins, without a prior the densest of all. The value is the precision-weighted mean of the
    objects within two standard deviations of the mode.
    """
    c = np.asarray(candidates, dtype=np.float64)
    s = np.asarray(sds, dtype=np.float64)
    ok = np.isfinite(c) & np.isfinite(s) & (c > -2 * bandwidth) & (c < max_speed + 2 * bandwidth)
    c, s = c[ok], s[ok]
    if c.size == 0:
        return None
    width = np.sqrt(bandwidth**2 + s**2)
    grid = np.arange(0.0, max_speed + 1e-9, bandwidth / 4.0)
    dens = (np.exp(-0.5 * ((grid[:, None] - c[None, :]) / width[None, :]) ** 2) / width).sum(1)
    edge = np.array([-1.0])  # (np.r_ costs ~30 us a call: this runs every frame)
    before, after = np.concatenate((edge, dens[:-1])), np.concatenate((dens[1:], edge))
    peak = np.flatnonzero((dens >= before) & (dens >= after) & (dens > 0))
    need = 1 if prior is not None else min_support
    best: tuple[float, float, float, int] | None = None  # density, speed, sd, support
    for k in peak.tolist():
        v = grid[k]
        if prior is not None and abs(v - prior) > reach:
            continue
        member = np.abs(c - v) <= 2.0 * width
        n = int(member.sum())
        if n < need:
            continue
        w = 1.0 / width[member] ** 2
        mean = float((w * c[member]).sum() / w.sum())
        sd = float(max(math.sqrt(1.0 / w.sum()), bandwidth / math.sqrt(n) / 2.0))
        if best is None or dens[k] > best[0]:
            best = (float(dens[k]), max(0.0, mean), sd, n)
    return None if best is None else (best[1], best[2], best[3])


class EgoEstimator:
    """The ego speed frame by frame: the static-object mode kept consistent over time, or the
    ego-motion file where it has the frame (:func:`estimate_ego_speed`)."""

    def __init__(
        self, fps: float, config: EgoMotionConfig | None = None, file: EgoMotion | None = None
    ):
        self.fps = float(fps)
        self.config = config or EgoMotionConfig()
        self.file = file
        self.reset()

    def reset(self) -> None:
        self._last: EgoState | None = None
        self._last_frame: int | None = None  # frame of the last estimate from the scene

    def update(
        self,
        frame: int,
        vz: np.ndarray,
        vx: np.ndarray,
        z: np.ndarray,
        x: np.ndarray,
        sd: np.ndarray,
    ) -> EgoState | None:
        """The ego state at ``frame`` from the relative velocities (N,) m/s of the tracks with
        one, their positions (N,) m and velocity standard errors (N,) m/s."""
        c = self.config
        with np.errstate(invalid="ignore"):
            near = (
                np.isfinite(vz)
                & (z <= c.static_range_m)
                & (np.abs(x) > c.ego_lane_half_m)
                & (sd <= c.max_vote_sd_mps)
            )
        cand, sds = -vz[near], sd[near]
        known = self.file.at(frame) if self.file is not None else None
        if known is not None:
            speed, yaw = known
            if yaw is None:
                yaw = self._yaw(speed, cand, sds, vx[near], z[near], x[near])
            return EgoState(speed, 0.1, yaw, 0, "file")
        prior = reach = None
        if self._last is not None and self._last_frame is not None:
            gap = (frame - self._last_frame) / self.fps
            if gap <= c.hold_s:
                prior = self._last.speed
                reach = c.max_accel_mps2 * gap + c.bandwidth_mps
        got = estimate_ego_speed(
            cand,
            sds,
            c.bandwidth_mps,
            c.max_speed_mps,
            prior=prior,
            reach=math.inf if reach is None else reach,
            min_support=c.min_static,
        )
        if got is None:
            if prior is None or self._last is None:
                self._last = None
                return None
            return EgoState(self._last.speed, self._last.sd, self._last.yaw_rate, 0, "held")
        speed, sd_v, n = got
        yaw = self._yaw(speed, cand, sds, vx[near], z[near], x[near])
        self._last, self._last_frame = EgoState(speed, sd_v, yaw, n, "scene"), frame
        return self._last

    def _yaw(
        self,
        speed: float,
        cand: np.ndarray,
        sds: np.ndarray,
        vx: np.ndarray,
        z: np.ndarray,
        x: np.ndarray,
    ) -> float:
        """Yaw rate (rad/s) from the static objects' lateral drift ``dX/dt = yaw * Z``: the
        median over the objects within two standard errors of ``speed`` (0 with fewer than
        two)."""
        width = np.sqrt(self.config.bandwidth_mps**2 + sds**2)
        member = (np.abs(cand - speed) <= 2.0 * width) & np.isfinite(vx) & (z > 0)
        if int(member.sum()) < 2:
            return 0.0
        return float(np.median(vx[member] / z[member]))


#: typical real height of an object of each class, metres (KITTI's label means: car 1.53,
#: pedestrian 1.76, cyclist 1.74); boxes of other classes do not vote on the horizon
OBJECT_HEIGHT_M: dict[int, float] = {
    CLASS_IDS["car"]: 1.53,
    CLASS_IDS["pedestrian"]: 1.76,
    CLASS_IDS["cyclist"]: 1.74,
}
#: boxes kept per frame for the horizon fit (the nearest first: their bottoms are the surest)
_HORIZON_BOXES_PER_FRAME = 40
#: boxes one fit uses at most (the latest): the pairwise slopes grow with the square
_HORIZON_MAX_POINTS = 240
#: smallest difference of ``h / H`` (px per metre) for a pair to give a slope
_HORIZON_MIN_DX = 3.0


def fit_horizon(x: np.ndarray, y: np.ndarray, height_m: float, band: float) -> tuple[float, float]:
    """Horizon row and slope of ``y = horizon + slope * x`` for boxes standing on the road.

    Args:
        x: (N,) box height over the object's real height, px per metre (``focal / Z``).
        y: (N,) box bottom rows, px.
        height_m: the camera's height above the road, metres: the slope expected.
        band: the slope is the median of the pairwise slopes (Theil-Sen), kept within
            ``height_m * (1 +- band)``; 0: the slope is ``height_m``.

    Returns ``(horizon_px, slope_m)``; the horizon is the median of ``y - slope * x``.
    """
    slope = height_m
    if band > 0 and x.size >= 2:
        i, j = np.triu_indices(x.size, 1)
        dx = x[j] - x[i]
        ok = np.abs(dx) >= _HORIZON_MIN_DX
        if ok.any():
            k = float(np.median((y[j] - y[i])[ok] / dx[ok]))
            slope = min(max(k, height_m * (1.0 - band)), height_m * (1.0 + band))
    return float(np.median(y - slope * x)), slope


class HorizonEstimator:
    """The horizon row (so the camera's pitch over the road) from the boxes of a scene.

    A pinhole camera ``height_m`` over a flat road sees an object of real height ``H`` standing
    on the road at distance Z with its box bottom at ``horizon + focal * height_m / Z`` and its
    box ``focal * H / Z`` tall, so over the untruncated boxes of the classes in
    :data:`OBJECT_HEIGHT_M` the bottom row is linear in ``h / H`` with slope ``height_m``
    (:func:`fit_horizon`). The fit is made over the last ``horizon_window_s`` seconds of boxes
    (at most ``_HORIZON_BOXES_PER_FRAME`` a frame and ``_HORIZON_MAX_POINTS`` in all: memory
    and time are bounded), kept within
    ``horizon_max_pitch_deg`` of level and smoothed with time constant ``horizon_smooth_s``;
    with fewer than ``horizon_min_boxes`` boxes in the window it relaxes back to level.
    """

    def __init__(
        self,
        camera: CameraModel,
        fps: float,
        config: EgoMotionConfig | None = None,
        image_size: tuple[int, int] | None = None,
    ):
        self.camera = camera
        self.fps = float(fps)
        self.config = config or EgoMotionConfig()
        self.image_size = image_size
        self._keep = max(1, int(round(self.config.horizon_window_s * self.fps)))
        self._limit = camera.focal_px * math.tan(math.radians(self.config.horizon_max_pitch_deg))
        self.reset()

    def reset(self) -> None:
        self._window: deque[tuple[int, np.ndarray, np.ndarray]] = deque()
        self.horizon_px = self.camera.horizon_px
        self.slope_m = self.camera.height_m
        self._frame: int | None = None

    @property
    def pitch_deg(self) -> float:
        """The camera's pitch over the road, degrees (positive: looking up, the horizon lower
        in the image than the level camera's)."""
        return math.degrees(
            math.atan((self.horizon_px - self.camera.horizon_px) / self.camera.focal_px)
        )

    def update(self, frame: int, xyxy: np.ndarray, classes: Sequence[int] | None = None) -> float:
        """The horizon row (px) at ``frame`` from the boxes ``xyxy`` (N, 4) px of this frame's
        visible objects, of classes ``classes`` (N,) (None: all cars)."""
        c = self.config
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        if classes is None:
            tall = np.full(len(b), OBJECT_HEIGHT_M[CLASS_IDS["car"]])
        else:
            tall = np.array([OBJECT_HEIGHT_M.get(int(k), np.nan) for k in classes], dtype=float)
        h = b[:, 3] - b[:, 1]
        ok = np.isfinite(tall) & (h > 0) & np.isfinite(b).all(axis=1)
        edge = 2.0  # a box this near the image's edge is cut: its bottom or height is not real
        ok &= (b[:, 0] > edge) & (b[:, 1] > edge)
        if self.image_size is not None:
            w, hh = self.image_size
            ok &= (b[:, 2] < w - 1 - edge) & (b[:, 3] < hh - 1 - edge)
        x, y = h[ok] / tall[ok], b[ok, 3]
        if x.size > _HORIZON_BOXES_PER_FRAME:
            near = np.argsort(-x)[:_HORIZON_BOXES_PER_FRAME]
            x, y = x[near], y[near]
        self._window.append((frame, x, y))
        while self._window and frame - self._window[0][0] >= self._keep:
            self._window.popleft()
        xs = np.concatenate([w[1] for w in self._window])[-_HORIZON_MAX_POINTS:]
        ys = np.concatenate([w[2] for w in self._window])[-_HORIZON_MAX_POINTS:]
        level = self.camera.horizon_px
        if xs.size >= c.horizon_min_boxes:
            raw, self.slope_m = fit_horizon(xs, ys, self.camera.height_m, c.horizon_height_band)
            target = min(max(raw, level - self._limit), level + self._limit)
        else:
            target = level
        dt = 1.0 / self.fps if self._frame is None else max(0, frame - self._frame) / self.fps
        self.horizon_px += (1.0 - math.exp(-dt / c.horizon_smooth_s)) * (target - self.horizon_px)
        self._frame = frame
        return self.horizon_px


@dataclass
class _History:
    frames: deque[int] = field(default_factory=deque)
    z: deque[float] = field(default_factory=deque)
    x: deque[float] = field(default_factory=deque)
    sd: deque[float] = field(default_factory=deque)


class WorldMotion:
    """Each frame's visible tracks in metres and m/s, and the ego state.

    Args:
        camera: the :class:`CameraModel` of the images.
        fps: frames per second.
        image_size: ``(width, height)`` pixels, or None.
        ego_motion: an ego-motion file's content
            (:func:`sensemaking.io.egomotion.read_ego_motion`), used where it has the frame;
            else the scene estimate.
        config: :class:`EgoMotionConfig`.

    ``update(frame, ids, xyxy, location)`` once per frame with the visible tracks; returns the
    :class:`EgoState` (None when unknown) and a :class:`TrackMotion` per track with a position.
    """

    def __init__(
        self,
        camera: CameraModel,
        fps: float,
        image_size: tuple[int, int] | None = None,
        ego_motion: EgoMotion | None = None,
        config: EgoMotionConfig | None = None,
    ):
        self.camera = camera
        self.fps = float(fps)
        self.image_size = image_size
        self.config = config or EgoMotionConfig()
        self.ego = EgoEstimator(fps, self.config, ego_motion)
        self.horizon = (
            HorizonEstimator(camera, fps, self.config, image_size)
            if self.config.horizon_from_scene
            else None
        )
        self._keep = max(3, int(round(self.config.fit_s * self.fps)) + 1)
        self.reset()

    def reset(self) -> None:
        self.ego.reset()
        if self.horizon is not None:
            self.horizon.reset()
        self._hist: dict[int, _History] = {}

    def forget(self, alive: set[int]) -> None:
        """Drop the history of tracks not in ``alive``."""
        for t in [t for t in self._hist if t not in alive]:
            del self._hist[t]

    def update(
        self,
        frame: int,
        ids: Sequence[int],
        xyxy: np.ndarray,
        location: np.ndarray | None = None,
        classes: Sequence[int] | None = None,
    ) -> tuple[EgoState | None, dict[int, TrackMotion]]:
        """Positions, relative and world velocities of the visible tracks ``ids`` with boxes
        ``xyxy`` (N, 4) px (and, where the detector gives them, 3D ``location`` (N, 3) camera
        coordinates, m, NaN where not) at ``frame``; ``classes`` (N,) class ids serve the
        horizon estimate (``horizon_from_scene``; None: all cars)."""
        c, cam = self.config, self.camera
        if self.horizon is not None:
            cam = replace(cam, horizon_px=self.horizon.update(frame, xyxy, classes))
        h = None if self.image_size is None else self.image_size[1]
        z, x = cam.ground_position(xyxy, h)
        zsd = cam.distance_sd(z, c.pixel_sd)
        if location is not None:
            loc = np.asarray(location, dtype=np.float64).reshape(-1, 3)
            has = np.isfinite(loc).all(axis=1) & (loc[:, 2] > 0)
            z = np.where(has, loc[:, 2], z)
            x = np.where(has, loc[:, 0], x)
            zsd = np.where(has, c.location_sd_m, zsd)
        n = len(ids)
        vz, vx, vsd = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
        fits: dict[int, list[int]] = {}  # rows to fit, by the length of their history
        for i, t in enumerate(ids):
            if not math.isfinite(z[i]):
                continue
            hist = self._hist.setdefault(t, _History())
            for d, v in zip(
                (hist.frames, hist.z, hist.x, hist.sd), (frame, z[i], x[i], zsd[i]), strict=True
            ):
                d.append(v)  # type: ignore[attr-defined]
            while hist.frames and (
                frame - hist.frames[0] > c.fit_s * self.fps or len(hist.frames) > self._keep
            ):
                for d in (hist.frames, hist.z, hist.x, hist.sd):
                    d.popleft()
            f0, f1 = hist.frames[0] / self.fps, hist.frames[-1] / self.fps  # seconds, as fitted
            if len(hist.frames) >= 3 and not f1 - f0 < c.min_span_s:
                fits.setdefault(len(hist.frames), []).append(i)
        for size, rows in fits.items():
            vz[rows], vx[rows], vsd[rows] = self._fit([self._hist[ids[i]] for i in rows], size)
        ego = self.ego.update(frame, vz, vx, z, x, np.where(np.isfinite(vsd), vsd, np.inf))
        out: dict[int, TrackMotion] = {}
        for i, t in enumerate(ids):
            if not math.isfinite(z[i]):
                continue
            zs = float(zsd[i])
            if not math.isfinite(vz[i]):
                out[t] = TrackMotion(float(z[i]), float(x[i]), zs)
                continue
            if ego is None:
                out[t] = TrackMotion(
                    float(z[i]), float(x[i]), zs, float(vz[i]), float(vx[i]), float(vsd[i])
                )
                continue
            w = ego.yaw_rate
            v_long = vz[i] + ego.speed + w * x[i]
            v_lat = vx[i] - w * z[i]
            sd = math.sqrt(vsd[i] ** 2 + ego.sd**2)
            out[t] = TrackMotion(
                float(z[i]),
                float(x[i]),
                zs,
                float(vz[i]),
                float(vx[i]),
                float(vsd[i]),
                float(v_long),
                float(v_lat),
                float(math.hypot(v_long, v_lat)),
                float(sd),
            )
        return ego, out

    def _fit(self, hists: list[_History], size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Least-squares velocities ``dZ/dt``, ``dX/dt`` (m/s) and the standard error of
        ``dZ/dt`` of histories of ``size`` positions each, one row a history: the arithmetic
        of one history at a time, row by row (numpy sums a row as it sums a 1-D array)."""
        tt = np.array([h.frames for h in hists], dtype=np.float64) / self.fps
        zz = np.array([h.z for h in hists], dtype=np.float64)
        xx = np.array([h.x for h in hists], dtype=np.float64)
        sd = np.array([h.sd for h in hists], dtype=np.float64)
        tc = tt - tt.mean(axis=1, keepdims=True)
        ss = (tc * tc).sum(axis=1)
        zc = zz.mean(axis=1, keepdims=True)
        vz = (tc * (zz - zc)).sum(axis=1) / ss
        vx = (tc * (xx - xx.mean(axis=1, keepdims=True))).sum(axis=1) / ss
        spread = np.sqrt((tc**2).sum(axis=1))
        model = sd.mean(axis=1) / spread
        resid = zz - (zc + vz[:, None] * tc)
        fit = np.sqrt((resid**2).sum(axis=1) / max(1, size - 2)) / spread
        return vz, vx, np.where(fit > model, fit, model)  # max(model, fit), as Python's max


def _cm(v: float) -> int:
    return int(round(v * 100.0))


def world_facts(
    ego: EgoState | None,
    motion: dict[int, TrackMotion],
    local: dict[int, int],
    g: int,
) -> list[tuple[object, ...]]:
    """The facts of one frame ``g`` (relative) for situations.lp, tracks by ``local`` index:
    ``camera`` (once, with the current frame ``g = 0``), ``ego_speed(G,V)``,
    ``position(T,G,Z,X)``, ``position_sd(T,G,E)``, ``closing(T,G,C,E)``,
    ``world_speed(T,G,S,E)``, ``world_long(T,G,V)``, ``world_lat(T,G,V)`` (centimetres, cm/s,
    integers; see situations.lp)."""
    out: list[tuple[object, ...]] = [("camera",)] if g == 0 else []
    if ego is not None:
        out.append(("ego_speed", g, _cm(ego.speed)))
    for t, m in motion.items():
        k = local.get(t)
        if k is None:
            continue
        out.append(("position", k, g, _cm(m.z), _cm(m.x)))
        out.append(("position_sd", k, g, _cm(m.z_sd)))
        if math.isfinite(m.vz):
            out.append(("closing", k, g, _cm(-m.vz), _cm(m.v_sd)))
        if math.isfinite(m.speed):
            out.append(("world_speed", k, g, _cm(m.speed), _cm(m.speed_sd)))
            out.append(("world_long", k, g, _cm(m.v_long)))
            out.append(("world_lat", k, g, _cm(m.v_lat)))
    return out


#: per scene: the world motion of its tracks, replayed once (scenes are not changed after
#: recording)
_REPLAYED: weakref.WeakKeyDictionary[Any, dict[int, list[TrackMotion]]] = (
    weakref.WeakKeyDictionary()
)


def scene_world_motion(
    scene: Scene, camera: CameraModel, config: EgoMotionConfig | None = None
) -> dict[int, list[TrackMotion]]:
    """Every track's :class:`TrackMotion` at each of its visible frames, by replaying the
    scene's frames through :class:`WorldMotion` (the ego speed estimated from the scene)."""
    from sensemaking.results import TrackState

    world = WorldMotion(camera, scene.fps, scene.image_size, None, config)
    out: dict[int, list[TrackMotion]] = {}
    for r in scene.frame_results():
        tr = r.tracks
        vis = np.asarray(tr.data["state"]) == int(TrackState.VISIBLE)
        ids = [] if tr.tracker_id is None else tr.tracker_id[vis].tolist()
        _, motion = world.update(r.frame, ids, tr.xyxy[vis])
        for t, m in motion.items():
            out.setdefault(t, []).append(m)
    return out


def world_story(scene: Scene, track_id: int) -> str | None:
    """One sentence on a track's motion over the road (km/h, metres), when the scene was
    recorded with a camera model (``metadata["camera"]``); None otherwise or when too little is
    known. "Stands still" uses the stop speed of situations.lp (``stop_cms``)."""
    record = scene.metadata.get("camera")
    if record is None:
        return None
    motion = _REPLAYED.get(scene)
    if motion is None:
        motion = _REPLAYED[scene] = scene_world_motion(scene, CameraModel.from_json(record))
    ms = motion.get(int(track_id), [])
    if not ms:
        return None
    from sensemaking.reasoning.situations import situation_constants

    z0, z1, x = ms[0].z, ms[-1].z, float(np.median([m.x for m in ms]))
    side = "ahead" if abs(x) < 1.0 else f"{abs(x):.0f} m to the {'right' if x > 0 else 'left'}"
    where = (
        f"from {z0:.0f} m to {z1:.0f} m ahead, {side}"
        if side != "ahead"
        else (f"from {z0:.0f} m to {z1:.0f} m ahead")
    )
    known = [m for m in ms if math.isfinite(m.speed)]
    if len(known) < 2:
        return f"It is {where} (its speed over the road is not known)."
    speed = float(np.median([m.speed for m in known]))
    v_long = float(np.median([m.v_long for m in known]))
    v_lat = float(np.median([m.v_lat for m in known]))
    if speed * 100.0 < situation_constants()["stop_cms"]:
        return f"It stands still, {where}."
    kmh = f"about {speed * 3.6:.0f} km/h"
    if abs(v_lat) > abs(v_long):
        how = f"crosses {'to the right' if v_lat > 0 else 'to the left'} at {kmh}"
    elif v_long > 0:
        how = f"drives the ego vehicle's way at {kmh}"
    else:
        how = f"comes towards the ego vehicle at {kmh}"
    return f"It {how}, {where}."

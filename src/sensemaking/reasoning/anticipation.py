"""Anticipating where and when a hidden object reappears (Figure 4 of the paper).

An object hidden behind an occluder keeps moving as it did when it was last seen; so does the
occluder. Both boxes are extrapolated from the last few visible boxes and the object
*reappears* at the first future frame at which less than ``reappear_coverage`` of its
extrapolated box is covered by the occluder's. The position there (bottom centre of the
extrapolated box, where the object stands on the road) is checked against the ego corridor; a
reappearance in the corridor is what HIDDEN_ENTITY warns about, while the object is still
hidden, with the lead time in frames and seconds.

Two motion models (``AnticipationConfig.motion_model``):

* ``linear`` (the default): each box corner moves at its own constant velocity in the image
  (least squares).
* ``pinhole`` (needs the image size, else ``linear``): each object moves at a constant
  velocity *relative to the camera* in 3D, seen through a pinhole camera whose principal point
  is the image centre ``(cx, cy)``. For an object of height H at depth Z(t) = Z0 + vz t, the box
  height is h = f H / Z, so ``1/h`` is linear in time; the box centre's offset from the
  principal point is f X / Z, so ``(x - cx) / h`` = X / H is linear in time, and so are
  ``(y2 - cy) / h`` (the bottom) and the aspect ``w / h``. These four are fitted by least
  squares over the last visible boxes and the box is rebuilt from them at any frame. A car
  passing close by accelerates across the image and grows; a distant one moves almost
  linearly: both follow from the same model. An object whose fitted ``1/h`` reaches zero has
  passed the camera: it does not come back into view (an occluder that has passed covers
  nothing). It fits the scale (``1/h``) from a few boxes, so box noise weighs more than in
  the linear model: measured on KITTI (docs/DESIGN-NOTES.md) it predicts near, fast-passing
  cars better and is no better overall, hence not the default.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from sensemaking.results import TrackState

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.reasoning.context import Corridor
    from sensemaking.scene import Scene

__all__ = [
    "AnticipationConfig",
    "Anticipation",
    "fit_motion",
    "anticipate",
    "anticipate_scene",
    "reappearance_errors",
    "ReappearanceError",
]


@dataclass(frozen=True)
class AnticipationConfig:
    """Parameters of anticipation.

    Attributes:
        reappear_coverage: the object has reappeared when less than this fraction of its box is
            covered by the occluder (match the detector's or tracker's occlusion threshold).
        horizon_s: how far ahead to look, seconds.
        velocity_points: visible boxes used to fit a velocity (the most recent ones).
        velocity_span_s: only boxes at most this long before the last visible one are used.
        motion_model: ``pinhole`` (constant 3D velocity relative to the camera; needs the image
            size, else ``linear``) or ``linear`` (constant image velocity of each box corner);
            see the module docstring.
    """

    reappear_coverage: float = 0.5
    horizon_s: float = 5.0
    velocity_points: int = 5
    velocity_span_s: float = 1.0
    motion_model: str = "linear"

    def __post_init__(self) -> None:
        if not 0 < self.reappear_coverage <= 1:
            raise ValueError("reappear_coverage must lie in (0, 1]")
        if self.horizon_s <= 0 or self.velocity_points < 1 or self.velocity_span_s <= 0:
            raise ValueError("horizon_s, velocity_points and velocity_span_s must be positive")
        if self.motion_model not in ("pinhole", "linear"):
            raise ValueError("motion_model must be 'pinhole' or 'linear'")


@dataclass(frozen=True)
class Anticipation:
    """A predicted reappearance.

    Attributes:
        track, occluder: track ids. frame: the frame the prediction was made at.
        reappear_frame: first frame at which the object is expected to be visible again.
        box: (x1, y1, x2, y2) extrapolated box there, pixels.
        position: (x, y) bottom centre of that box, pixels.
        lead_frames, lead_s: time from ``frame`` to ``reappear_frame``, frames and seconds.
        in_corridor: the box there stands in the ego corridor (False without an image size).
        in_image: the box centre there lies inside the image (True without an image size).
        overdue: the extrapolation says the object should already be visible (it stopped, or
            the motion changed); the reappearance is then expected at the next frame.
    """

    track: int
    occluder: int
    frame: int
    reappear_frame: int
    box: tuple[float, float, float, float]
    position: tuple[float, float]
    lead_frames: int
    lead_s: float
    in_corridor: bool
    in_image: bool
    overdue: bool = False

    def to_json(self) -> dict[str, Any]:
        return {
            "track": self.track,
            "occluder": self.occluder,
            "frame": self.frame,
            "reappear_frame": self.reappear_frame,
            "box": [round(v, 1) for v in self.box],
            "position": [round(v, 1) for v in self.position],
            "lead_frames": self.lead_frames,
            "lead_s": round(self.lead_s, 3),
            "in_corridor": self.in_corridor,
            "in_image": self.in_image,
            "overdue": self.overdue,
        }


def fit_motion(
    frames: np.ndarray, xyxy: np.ndarray, points: int = 5, span: float | None = None
) -> tuple[int, np.ndarray, np.ndarray]:
    """Linear fit of a box over its last visible frames.

    Args:
        frames: (K,) increasing frame numbers (K >= 1). xyxy: (K, 4) boxes, pixels.
        points: use at most this many of the latest boxes.
        span: ... and only those at most ``span`` frames before the latest.

    Returns:
        ``(last_frame, box, velocity)``: the latest frame, the fitted (4,) box at it (pixels) and
        the (4,) corner velocities in pixels per frame (zeros from a single box).
    """
    f = np.asarray(frames, dtype=np.float64).reshape(-1)[-points:]
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)[-points:]
    if f.shape[0] == 0:
        raise ValueError("fit_motion needs at least one box")
    if span is not None:
        keep = f >= f[-1] - span
        f, x = f[keep], x[keep]
    last = int(f[-1])
    if f.shape[0] < 2:
        return last, x[-1].copy(), np.zeros(4)
    t = f - f[-1]
    tm = t.mean()
    xm = x.mean(axis=0)
    denom = float(((t - tm) ** 2).sum())
    vel = ((t - tm)[:, None] * (x - xm)).sum(axis=0) / denom
    box = xm + vel * (0.0 - tm)
    return last, box, vel


def _box_at(last: int, box: list[float], vel: list[float], frame: int) -> list[float]:
    """The box ``box + vel * (frame - last)`` (pixels; ``vel`` per frame) about the same centre
    with each side kept >= 1 px."""
    dt = float(frame) - last
    x1, y1, x2, y2 = (
        box[0] + vel[0] * dt,
        box[1] + vel[1] * dt,
        box[2] + vel[2] * dt,
        box[3] + vel[3] * dt,
    )
    cx, cy = (x1 + x2) / 2, (y1 + y2) / 2
    hw, hh = x2 - x1, y2 - y1
    hw = (hw if hw >= 1.0 else 1.0) / 2
    hh = (hh if hh >= 1.0 else 1.0) / 2
    return [cx - hw, cy - hh, cx + hw, cy + hh]


def _coverage(a: list[float], b: list[float]) -> float:
    """Fraction of box ``a`` covered by box ``b``."""
    w = (a[2] if a[2] < b[2] else b[2]) - (a[0] if a[0] > b[0] else b[0])
    h = (a[3] if a[3] < b[3] else b[3]) - (a[1] if a[1] > b[1] else b[1])
    area = (a[2] - a[0]) * (a[3] - a[1])
    return (w if w > 0 else 0.0) * (h if h > 0 else 0.0) / (area if area >= 1e-9 else 1e-9)


def _first_uncovered(
    t_last: int,
    t_box: list[float],
    t_vel: list[float],
    o_last: int,
    o_box: list[float],
    o_vel: list[float],
    now: int,
    steps: int,
    coverage: float,
) -> tuple[int, list[float], bool] | None:
    """``(k, box, overdue)`` for the first of the frames ``now + 1 .. now + steps`` at which the
    extrapolated object is less than ``coverage`` covered, or None if there is none."""
    overdue = (
        _coverage(_box_at(t_last, t_box, t_vel, now), _box_at(o_last, o_box, o_vel, now))
        < coverage
    )
    for k in range(1, steps + 1):
        box = _box_at(t_last, t_box, t_vel, now + k)
        if _coverage(box, _box_at(o_last, o_box, o_vel, now + k)) < coverage:
            return k, box, overdue and k == 1
    return None


class _Pinhole:
    """A box moving at a constant 3D velocity relative to a pinhole camera: ``(1/h, (xc - cx)/h,
    (y2 - cy)/h, w/h)`` linear in the frame number (fitted by :func:`fit_motion`)."""

    __slots__ = ("last", "q", "dq", "cx", "cy")

    def __init__(
        self, frames: np.ndarray, xyxy: np.ndarray, points: int, span: float, centre: tuple
    ) -> None:
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        h = np.maximum(b[:, 3] - b[:, 1], 1.0)
        self.cx, self.cy = centre
        q = np.stack(
            [
                1.0 / h,
                ((b[:, 0] + b[:, 2]) / 2 - self.cx) / h,
                (b[:, 3] - self.cy) / h,
                np.maximum(b[:, 2] - b[:, 0], 1.0) / h,
            ],
            axis=1,
        )
        last, q0, dq = fit_motion(frames, q, points, span)
        self.last, self.q, self.dq = last, q0.tolist(), dq.tolist()

    def box(self, frame: int) -> list[float] | None:
        """The box at ``frame`` (pixels), None once the object has passed the camera."""
        dt = float(frame) - self.last
        u = self.q[0] + self.dq[0] * dt
        if u <= 1e-6:  # 1/h at zero: the object is at the camera's plane
            return None
        h = 1.0 / u
        xc = self.cx + (self.q[1] + self.dq[1] * dt) * h
        y2 = self.cy + (self.q[2] + self.dq[2] * dt) * h
        hw = max((self.q[3] + self.dq[3] * dt) * h, 1.0) / 2
        return [xc - hw, y2 - h, xc + hw, y2]


def _first_uncovered_pinhole(
    t: _Pinhole, o: _Pinhole, now: int, steps: int, coverage: float
) -> tuple[int, list[float], bool] | None:
    """:func:`_first_uncovered` for the pinhole motion model; None also when the object passes
    the camera first."""

    def covered(k: int) -> tuple[list[float] | None, bool]:
        tb = t.box(now + k)
        if tb is None:
            return None, False
        ob = o.box(now + k)
        return tb, ob is None or _coverage(tb, ob) < coverage

    tb, out = covered(0)
    if tb is None:
        return None
    overdue = out
    for k in range(1, steps + 1):
        tb, out = covered(k)
        if tb is None:
            return None
        if out:
            return k, tb, overdue and k == 1
    return None


def anticipate(
    hidden_frames: np.ndarray,
    hidden_xyxy: np.ndarray,
    occluder_frames: np.ndarray,
    occluder_xyxy: np.ndarray,
    now: int,
    *,
    fps: float,
    track: int = -1,
    occluder: int = -1,
    image_size: tuple[int, int] | None = None,
    corridor: Corridor | None = None,
    config: AnticipationConfig | None = None,
) -> Anticipation | None:
    """When and where a hidden object may reappear from behind its occluder.

    Args:
        hidden_frames, hidden_xyxy: (K,) frames and (K, 4) boxes (pixels) of the hidden object
            while it was visible, up to the last time it was seen.
        occluder_frames, occluder_xyxy: (M,) frames and (M, 4) boxes of the occluder, latest
            last (up to ``now`` if it is visible).
        now: the current frame (the object is hidden now).
        fps: frames per second. track, occluder: ids stored in the result.
        image_size: ``(width, height)``, for the corridor and image checks.
        corridor: the ego corridor (default :class:`~sensemaking.reasoning.context.Corridor`).
        config: :class:`AnticipationConfig`.

    Returns:
        An :class:`Anticipation`, or None when the object does not come out from behind the
        occluder within the horizon (they move together, or either history is empty).
    """
    from sensemaking.reasoning.context import Corridor

    c = config or AnticipationConfig()
    if len(hidden_frames) == 0 or len(occluder_frames) == 0:
        return None
    span = c.velocity_span_s * fps
    horizon = max(1, int(round(c.horizon_s * fps)))
    if c.motion_model == "pinhole" and image_size is not None:
        centre = (image_size[0] / 2.0, image_size[1] / 2.0)
        pt = _Pinhole(hidden_frames, hidden_xyxy, c.velocity_points, span, centre)
        po = _Pinhole(occluder_frames, occluder_xyxy, c.velocity_points, span, centre)
        found = _first_uncovered_pinhole(pt, po, now, horizon, c.reappear_coverage)
    else:
        t_last, t_box, t_vel = fit_motion(hidden_frames, hidden_xyxy, c.velocity_points, span)
        o_last, o_box, o_vel = fit_motion(occluder_frames, occluder_xyxy, c.velocity_points, span)
        found = _first_uncovered(
            t_last,
            t_box.tolist(),
            t_vel.tolist(),
            o_last,
            o_box.tolist(),
            o_vel.tolist(),
            now,
            horizon,
            c.reappear_coverage,
        )
    if found is None:
        return None
    k, box, overdue = found
    pos = ((box[0] + box[2]) / 2, box[3])
    in_corridor, in_image = False, True
    if image_size is not None:
        corr = corridor or Corridor()
        in_corridor = bool(corr.contains_boxes(np.array([box]), image_size)[0])
        cx, cy = (box[0] + box[2]) / 2, (box[1] + box[3]) / 2
        in_image = bool(0 <= cx <= image_size[0] and 0 <= cy <= image_size[1])
        in_corridor = in_corridor and in_image
    return Anticipation(
        track=int(track),
        occluder=int(occluder),
        frame=int(now),
        reappear_frame=int(now + k),
        box=(box[0], box[1], box[2], box[3]),
        position=pos,
        lead_frames=k,
        lead_s=k / float(fps),
        in_corridor=in_corridor,
        in_image=in_image,
        overdue=overdue,
    )


def anticipate_scene(
    scene: Scene,
    frame: int,
    *,
    corridor: Corridor | None = None,
    config: AnticipationConfig | None = None,
) -> list[Anticipation]:
    """Anticipations for every track hidden at ``frame``, from what was seen up to ``frame``."""
    out = []
    for t in scene.tracks.values():
        i = t.index(frame)
        if i is None or t.state[i] != TrackState.HIDDEN or t.occluder[i] < 0:
            continue
        o = scene.tracks.get(int(t.occluder[i]))
        if o is None:
            continue
        vis = t.visible_mask()[: i + 1]
        oi = np.flatnonzero(o.frames <= frame)
        ovis = oi[o.visible_mask()[oi]]
        j = o.index(frame)
        if j is not None and (ovis.size == 0 or ovis[-1] != j):
            ovis = np.append(ovis, j)  # its box now (a prediction when not visible) anchors it
        a = anticipate(
            t.frames[: i + 1][vis],
            t.xyxy[: i + 1][vis],
            o.frames[ovis],
            o.xyxy[ovis],
            frame,
            fps=scene.fps,
            track=t.id,
            occluder=o.id,
            image_size=scene.image_size,
            corridor=corridor,
            config=config,
        )
        if a is not None:
            out.append(a)
    return out


@dataclass(frozen=True)
class ReappearanceError:
    """Prediction made when a track hid, against what happened.

    Attributes:
        track, occluder: ids. hidden_from: first hidden frame (the prediction's ``frame``).
        predicted_frame, actual_frame: predicted and observed first visible frame afterwards.
        frame_error: ``predicted - actual`` frames. position_error_px: distance between the
            predicted bottom centre and the observed one at ``actual_frame`` (pixels).
        predicted_position, actual_position: bottom centres, pixels.
    """

    track: int
    occluder: int
    hidden_from: int
    predicted_frame: int
    actual_frame: int
    frame_error: int
    position_error_px: float
    predicted_position: tuple[float, float]
    actual_position: tuple[float, float]

    def to_json(self) -> dict[str, Any]:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return {k: list(v) if isinstance(v, tuple) else v for k, v in values.items()}


def reappearance_errors(
    scene: Scene, *, corridor: Corridor | None = None, config: AnticipationConfig | None = None
) -> list[ReappearanceError]:
    """For every hidden episode that ends with the track visible again: the prediction made at
    its first hidden frame against the observed reappearance (frame and bottom-centre position)."""
    out = []
    for ep in scene.fluent_intervals("hidden_by"):
        t = scene.tracks[ep.args[0]]
        after = np.flatnonzero((t.frames > ep.end) & t.visible_mask())
        if after.size == 0:
            continue
        k = int(after[0])
        preds = [
            a
            for a in anticipate_scene(scene, ep.start, corridor=corridor, config=config)
            if a.track == t.id
        ]
        if not preds:
            continue
        a = preds[0]
        b = t.xyxy[k]
        actual = (float((b[0] + b[2]) / 2), float(b[3]))
        err = float(np.hypot(a.position[0] - actual[0], a.position[1] - actual[1]))
        out.append(
            ReappearanceError(
                t.id,
                a.occluder,
                ep.start,
                a.reappear_frame,
                int(t.frames[k]),
                a.reappear_frame - int(t.frames[k]),
                err,
                a.position,
                actual,
            )
        )
    return out

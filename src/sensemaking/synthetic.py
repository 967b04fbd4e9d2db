"""Synthetic scenes with ground truth: scalability benchmarks and occlusion test cases.

Every scene is rendered the same way from object trajectories (boxes per frame):

* Depth follows the ground plane: an object is *in front of* (nearer than) another when its
  box bottom ``y2`` is larger. Objects at exactly the same ``y2`` do not occlude each other.
* Boxes are clipped to the image; an object is in the image (ground truth, and possibly a
  detection) on frames where at least 30 % of its box is inside.
* ``visibility`` = fraction of the (clipped) box not covered by the union of nearer boxes.
  The detector misses an object when more than ``occlusion_threshold`` of it is covered
  (visibility < 1 - occlusion_threshold), and otherwise with probability ``miss_rate``.
* Detections are the ground-truth boxes plus Gaussian corner noise (``noise_px``), with a
  confidence that falls with occlusion; false positives are random boxes of realistic sizes.
  Within a frame detections are shuffled (a detector's output order carries no identity).

Object ids (``tracker_id`` of the ground truth, ``data["gt_id"]`` of the detections) are
1-based; false positives have ``gt_id == -1``. Frames are numbered from 0.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TypedDict, Unpack

import numpy as np

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.geometry import iou

__all__ = [
    "SyntheticScene",
    "make_scene",
    "crossing_scene",
    "occlusion_suite",
    "overlap_fraction",
    "figure1_scene",
]

#: fraction of a box that must be inside the image for the object to be in the scene
MIN_INSIDE = 0.3

#: typical width / height of a box per class (KITTI-like); other classes use 1.0
_ASPECT: dict[int, float] = {
    CLASS_IDS["pedestrian"]: 0.41,
    CLASS_IDS["person_on_vehicle"]: 0.6,
    CLASS_IDS["static_person"]: 0.41,
    CLASS_IDS["person_sitting"]: 0.8,
    CLASS_IDS["cyclist"]: 0.65,
    CLASS_IDS["bicycle"]: 0.65,
    CLASS_IDS["motorbike"]: 0.7,
    CLASS_IDS["car"]: 1.7,
    CLASS_IDS["van"]: 1.5,
    CLASS_IDS["truck"]: 1.3,
    CLASS_IDS["tram"]: 2.5,
}
#: typical box height in pixels of an object ~15 m ahead in a KITTI frame
_HEIGHT: dict[int, float] = {
    CLASS_IDS["pedestrian"]: 110.0,
    CLASS_IDS["cyclist"]: 100.0,
    CLASS_IDS["car"]: 80.0,
    CLASS_IDS["van"]: 100.0,
    CLASS_IDS["truck"]: 130.0,
    CLASS_IDS["tram"]: 140.0,
}


@dataclass(frozen=True, eq=False)
class SyntheticScene:
    """A rendered scene: detector output plus ground truth.

    Attributes:
        detections: what a detector would output; ``frame``, ``class_id`` and ``confidence``
            (in (0, 1]) set, ``tracker_id`` -1, ``data["gt_id"]`` the object id (-1: false
            positive). Sorted by frame, shuffled within a frame.
        ground_truth: every object on every frame it is in the image, boxes clipped to the
            image; ``tracker_id`` = object id, ``confidence`` 1, ``data["visibility"]`` the
            fraction not covered by nearer objects. Sorted by frame, then id.
        width, height: image size, pixels. fps: frames per second. n_frames: frames 0..n_frames-1.
        name: short description (for test ids and reports).
    """

    detections: Detections
    ground_truth: Detections
    width: int
    height: int
    fps: float
    n_frames: int
    name: str = ""

    def frames(self) -> Iterator[tuple[int, Detections]]:
        """Yield ``(frame, detections)`` for every frame 0..n_frames-1 in order; frames
        without detections give an empty Detections (same ``data`` keys)."""
        det, frame = self.detections, self.detections.frame
        assert frame is not None  # Detections fills every column
        if np.any(np.diff(frame) < 0):
            order = np.argsort(frame, kind="stable")
            det, frame = det[order], frame[order]
        cuts = np.searchsorted(frame, np.arange(self.n_frames + 1), side="left")
        for f in range(self.n_frames):
            yield f, det[cuts[f] : cuts[f + 1]]

    def __repr__(self) -> str:
        assert self.ground_truth.tracker_id is not None
        return (
            f"SyntheticScene({self.name!r}, n_frames={self.n_frames}, "
            f"objects={np.unique(self.ground_truth.tracker_id).size}, "
            f"detections={len(self.detections)})"
        )


def overlap_fraction(boxes: Detections) -> float:
    """Mean over frames of the fraction of boxes that overlap (IoU > 0) another box of the
    same frame; frames without boxes are skipped, 0.0 if there are none."""
    fractions = []
    for _, frame in boxes.frames():
        if len(frame) < 2:
            fractions.append(0.0)
            continue
        m = iou(frame.xyxy, frame.xyxy) > 0
        np.fill_diagonal(m, False)
        fractions.append(float(m.any(axis=1).mean()))
    return float(np.mean(fractions)) if fractions else 0.0


# rendering -------------------------------------------------------------------------------
def _intersects(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) whether boxes ``a`` (N, 4) and ``b`` (M, 4) share a positive area."""
    w = np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0])
    h = np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1])
    return (w > 0) & (h > 0)


def _union_area(rects: np.ndarray) -> float:
    """Area of the union of (K, 4) xyxy rectangles (coordinate compression; K is small)."""
    xs = np.unique(rects[:, [0, 2]])
    ys = np.unique(rects[:, [1, 3]])
    cx = 0.5 * (xs[:-1] + xs[1:])
    cy = 0.5 * (ys[:-1] + ys[1:])
    inside = (
        (rects[:, None, None, 0] <= cx[None, :, None])
        & (cx[None, :, None] <= rects[:, None, None, 2])
        & (rects[:, None, None, 1] <= cy[None, None, :])
        & (cy[None, None, :] <= rects[:, None, None, 3])
    )
    cell = np.diff(xs)[:, None] * np.diff(ys)[None, :]
    return float(cell[inside.any(axis=0)].sum())


def _render(
    cxcywh: np.ndarray,
    exists: np.ndarray,
    class_id: np.ndarray,
    *,
    width: int,
    height: int,
    fps: float,
    occlusion_threshold: float,
    miss_rate: float,
    false_positive_rate: float,
    noise_px: float,
    rng: np.random.Generator,
    name: str,
) -> SyntheticScene:
    """A scene from trajectories ``cxcywh`` (F, N, 4) pixels, alive where ``exists`` (F, N)."""
    n_frames, n_obj = exists.shape
    c = cxcywh
    full = np.concatenate([c[..., :2] - c[..., 2:] / 2, c[..., :2] + c[..., 2:] / 2], axis=-1)
    clipped = full.copy()
    clipped[..., [0, 2]] = np.clip(clipped[..., [0, 2]], 0.0, width)
    clipped[..., [1, 3]] = np.clip(clipped[..., [1, 3]], 0.0, height)
    area_full = np.clip(c[..., 2], 0, None) * np.clip(c[..., 3], 0, None)
    area = (clipped[..., 2] - clipped[..., 0]) * (clipped[..., 3] - clipped[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        inside = np.where(area_full > 0, area / np.where(area_full > 0, area_full, 1.0), 0.0)
    present = exists & (area_full > 0) & (inside >= MIN_INSIDE)

    # occlusion: union of the parts covered by nearer (larger y2) objects, (F, N). Only pairs
    # whose boxes meet on some frame are examined, so sparse scenes stay cheap.
    covered = np.zeros((n_frames, n_obj))
    n_occluders = np.zeros((n_frames, n_obj), dtype=np.int64)
    big = np.where(present[..., None], clipped, np.array([np.inf, np.inf, -np.inf, -np.inf]))
    hull = np.concatenate([big[..., :2].min(axis=0), big[..., 2:].max(axis=0)], axis=1)  # (N, 4)
    first, second = np.nonzero(np.triu(_intersects(hull, hull), k=1))
    if first.size:
        a, b = clipped[:, first], clipped[:, second]  # (F, P, 4)
        iw = np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0])
        ih = np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1])
        meet = (iw > 0) & (ih > 0) & present[:, first] & present[:, second]
        inter = np.where(meet, iw * ih, 0.0)
        y2 = full[..., 3]
        b_hides_a = meet & (y2[:, second] > y2[:, first])  # (F, P)
        a_hides_b = meet & (y2[:, first] > y2[:, second])
        for hidden, hides in ((first, b_hides_a), (second, a_hides_b)):
            cols = (slice(None), hidden)
            # numpy's stubs omit the tuple-with-slices index that ufunc.at documents and accepts
            np.add.at(covered, cols, np.where(hides, inter, 0.0))  # type: ignore[arg-type]
            np.add.at(n_occluders, cols, hides.astype(np.int64))  # type: ignore[arg-type]
        for f, i in zip(*np.nonzero(n_occluders > 1), strict=True):  # overlapping occluders
            others = np.concatenate(
                [second[(first == i) & b_hides_a[f]], first[(second == i) & a_hides_b[f]]]
            )
            box = clipped[f, i]
            parts = clipped[f, others].copy()
            parts[:, :2] = np.maximum(parts[:, :2], box[:2])
            parts[:, 2:] = np.minimum(parts[:, 2:], box[2:])
            covered[f, i] = _union_area(parts)
    with np.errstate(divide="ignore", invalid="ignore"):
        covered_frac = np.where(
            present, np.clip(covered / np.where(area > 0, area, 1.0), 0.0, 1.0), 0.0
        )
    visibility = 1.0 - covered_frac

    # random draws with fixed shapes, so one rate does not change the others' randomness
    u_miss = rng.random((n_frames, n_obj))
    noise = rng.normal(0.0, 1.0, (n_frames, n_obj, 4)) * noise_px
    conf_noise = rng.normal(0.0, 0.05, (n_frames, n_obj))

    ids = np.arange(1, n_obj + 1, dtype=np.int64)
    f_gt, o_gt = np.nonzero(present)  # frame-major, then object id
    ground_truth = Detections(
        xyxy=clipped[f_gt, o_gt],
        class_id=class_id[o_gt],
        tracker_id=ids[o_gt],
        frame=f_gt,
        data={"visibility": visibility[f_gt, o_gt]},
    )

    seen = present & (covered_frac <= occlusion_threshold) & (u_miss >= miss_rate)
    f_d, o_d = np.nonzero(seen)
    boxes = _clean_boxes(clipped[f_d, o_d] + noise[f_d, o_d], width, height)
    conf = np.clip(0.5 + 0.45 * visibility[f_d, o_d] + conf_noise[f_d, o_d], 0.05, 1.0)
    det_class, det_gt = class_id[o_d], ids[o_d]

    if false_positive_rate > 0 and len(ground_truth):
        per_frame = np.bincount(f_d, minlength=n_frames)
        n_fp = rng.poisson(false_positive_rate * per_frame)
        total = int(n_fp.sum())
        f_fp = np.repeat(np.arange(n_frames), n_fp)
        template = rng.integers(0, len(ground_truth), total)  # size and class of a real object
        wh = ground_truth.xyxy[template, 2:] - ground_truth.xyxy[template, :2]
        wh = np.minimum(wh, [width, height])
        x1 = rng.random(total) * (width - wh[:, 0])
        y1 = rng.random(total) * (height - wh[:, 1])
        fp_boxes = np.column_stack([x1, y1, x1 + wh[:, 0], y1 + wh[:, 1]])
        f_d = np.concatenate([f_d, f_fp])
        boxes = np.concatenate([boxes, fp_boxes])
        conf = np.concatenate([conf, rng.uniform(0.05, 0.5, total)])
        assert ground_truth.class_id is not None
        det_class = np.concatenate([det_class, ground_truth.class_id[template]])
        det_gt = np.concatenate([det_gt, np.full(total, -1, dtype=np.int64)])

    order = np.lexsort((rng.random(f_d.size), f_d))
    detections = Detections(
        xyxy=boxes[order],
        confidence=conf[order],
        class_id=det_class[order],
        frame=f_d[order],
        data={"gt_id": det_gt[order]},
    )
    return SyntheticScene(
        detections=detections,
        ground_truth=ground_truth,
        width=int(width),
        height=int(height),
        fps=float(fps),
        n_frames=int(n_frames),
        name=name,
    )


def _clean_boxes(xyxy: np.ndarray, width: float, height: float) -> np.ndarray:
    """Order corners, clip to the image and keep boxes at least 1 px wide and tall."""
    out = np.empty_like(xyxy)
    out[:, :2] = np.minimum(xyxy[:, :2], xyxy[:, 2:])
    out[:, 2:] = np.maximum(xyxy[:, :2], xyxy[:, 2:])
    for lo, hi, size in ((0, 2, width), (1, 3, height)):
        out[:, [lo, hi]] = np.clip(out[:, [lo, hi]], 0.0, size)
        short = out[:, hi] - out[:, lo] < 1.0
        out[short, hi] = np.minimum(out[short, lo] + 1.0, size)
        out[short, lo] = out[short, hi] - 1.0
    return out


def _check_rates(
    occlusion_threshold: float, miss_rate: float, false_positive_rate: float, noise_px: float
) -> None:
    if not 0.0 <= occlusion_threshold <= 1.0:
        raise ValueError(f"occlusion_threshold must be in [0, 1], got {occlusion_threshold}")
    if not 0.0 <= miss_rate <= 1.0:
        raise ValueError(f"miss_rate must be in [0, 1], got {miss_rate}")
    if not false_positive_rate >= 0.0:
        raise ValueError(f"false_positive_rate must be >= 0, got {false_positive_rate}")
    if not noise_px >= 0.0:
        raise ValueError(f"noise_px must be >= 0, got {noise_px}")


# scalability scenes ----------------------------------------------------------------------
_DY = 0.12  # bottom offset between depth levels in a group, fraction of box height
_GROW = 0.05  # size increase per depth level in a group (nearer = larger)
_SWING = 0.45  # max horizontal offset of a group member from the group centre, x box width
_FILL = 0.8  # max fraction of a cell's side taken by a unit's envelope (rest: motion)


def make_scene(
    n_tracks: int,
    n_frames: int = 100,
    overlap: float = 0.3,
    width: int = 1242,
    height: int = 375,
    fps: float = 10.0,
    occlusion_threshold: float = 0.6,
    miss_rate: float = 0.0,
    false_positive_rate: float = 0.0,
    noise_px: float = 1.0,
    classes: Sequence[int] = (3,),
    seed: int = 0,
) -> SyntheticScene:
    """A scene of ``n_tracks`` objects, all in the image on every frame, of which a fraction
    ``overlap`` overlap (IoU > 0) another object on every frame.

    Layout: the image is cut into a grid of cells, one per *unit*; a unit is a single object
    or a group of 2-3 overlapping objects (similar size, same class, stacked in depth, sliding
    past each other so that the far ones are often partly or fully hidden). Each unit drifts
    at constant velocity and changes size linearly, staying inside its cell, so units never
    overlap each other: the measured :func:`overlap_fraction` is ``ceil(overlap * n_tracks) /
    n_tracks`` (at least 2 objects when ``overlap > 0``, none if ``n_tracks < 2``).

    Args:
        n_tracks: number of objects (>= 0).
        n_frames: frames 0..n_frames-1 (>= 1).
        overlap: target fraction of objects overlapping another, in [0, 1].
        width, height: image size, pixels. fps: frame rate (metadata only).
        occlusion_threshold: covered fraction above which the detector misses an object.
        miss_rate: probability of missing each remaining object per frame.
        false_positive_rate: expected false positives per true detection (Poisson per frame).
        noise_px: std of the Gaussian noise on detection corners, pixels.
        classes: class ids to draw from (uniformly per unit); sizes follow the class.
        seed: seed of ``np.random.default_rng``; equal seeds give equal scenes.
    """
    if n_tracks < 0 or n_frames < 1:
        raise ValueError("need n_tracks >= 0 and n_frames >= 1")
    if not 0.0 <= overlap <= 1.0:
        raise ValueError(f"overlap must be in [0, 1], got {overlap}")
    if len(classes) == 0:
        raise ValueError("classes must not be empty")
    _check_rates(occlusion_threshold, miss_rate, false_positive_rate, noise_px)
    rng = np.random.default_rng(seed)

    n_over = (
        0
        if overlap == 0 or n_tracks < 2
        else min(n_tracks, max(2, math.ceil(overlap * n_tracks - 1e-9)))
    )
    groups = [2] * (n_over // 2)
    if n_over % 2:
        groups[-1] = 3
    sizes = np.array(groups + [1] * (n_tracks - n_over), dtype=np.int64)
    rng.shuffle(sizes)
    n_units = sizes.size
    unit_class = np.asarray(classes, dtype=np.int64)[rng.integers(0, len(classes), n_units)]
    aspect = np.array([_ASPECT.get(int(k), 1.0) for k in unit_class]) * rng.uniform(
        0.9, 1.1, n_units
    )
    hfac = 1.0 + _DY * (sizes - 1)  # envelope height / h
    wfac = 1.0 + _GROW * (sizes - 1) + np.where(sizes > 1, 2 * _SWING, 0.0)  # envelope width / w

    # grid of cells roughly shaped like the units
    if n_units:
        unit_aspect = float(np.mean(aspect * wfac / hfac))
        cols = max(1, min(n_units, round(math.sqrt(n_units * width / height / unit_aspect))))
        rows = math.ceil(n_units / cols)
    else:
        cols = rows = 1
    cw, ch = width / cols, height / rows
    cell = rng.permutation(rows * cols)[:n_units]
    x_lo, y_lo = (cell % cols) * cw, (cell // cols) * ch

    h_fit = np.minimum(np.minimum(_FILL * ch / hfac, _FILL * cw / (wfac * aspect)), 150.0)
    if n_units and h_fit.min() < 4.0:
        raise ValueError(f"{n_tracks} tracks do not fit a {width}x{height} image")
    h_big = h_fit * rng.uniform(0.75, 1.0, n_units)
    h_small = h_big * rng.uniform(0.8, 1.0, n_units)
    grows = rng.random(n_units) < 0.5
    h_ends = np.stack([np.where(grows, h_small, h_big), np.where(grows, h_big, h_small)])  # (2, U)
    half_w = 0.5 * wfac * aspect * h_ends
    env_h = hfac * h_ends
    u = rng.random((4, 2, n_units))
    margin = 1.0
    ecx = x_lo + margin + half_w + u[0] * (cw - 2 * margin - 2 * half_w)  # (2, U) start, end
    ebot = y_lo + margin + env_h + u[1] * (ch - 2 * margin - env_h)

    # members: depth level k = 0 (farthest) .. g-1 (nearest)
    unit = np.repeat(np.arange(n_units), sizes)
    level = np.arange(unit.size) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    g = sizes[unit]
    off = rng.uniform(-_SWING, _SWING, (2, unit.size)) * (g > 1)  # x w, start and end
    tau = (np.arange(n_frames) / max(n_frames - 1, 1))[:, None]  # (F, 1)

    def lerp(ends: np.ndarray) -> np.ndarray:
        return ends[0][None, :] + tau * (ends[1] - ends[0])[None, :]

    h_u = lerp(h_ends[:, unit])
    a_u = aspect[unit]
    h_m = h_u * (1.0 + _GROW * level)
    cx = lerp(ecx[:, unit]) + lerp(off) * a_u * h_u
    bottom = lerp(ebot[:, unit]) - (g - 1 - level) * _DY * h_u
    cxcywh = np.stack([cx, bottom - h_m / 2, a_u * h_m, h_m], axis=-1)
    exists = np.ones((n_frames, unit.size), dtype=bool)
    return _render(
        cxcywh,
        exists,
        unit_class[unit],
        width=width,
        height=height,
        fps=fps,
        occlusion_threshold=occlusion_threshold,
        miss_rate=miss_rate,
        false_positive_rate=false_positive_rate,
        noise_px=noise_px,
        rng=rng,
        name=f"synthetic_{n_tracks}tracks_{round(100 * overlap)}pct_seed{seed}",
    )


# hand-made occlusion scenes -------------------------------------------------------------
def _keyframed(n_frames: int, keys: Sequence[Sequence[float]]) -> tuple[np.ndarray, np.ndarray]:
    """Trajectory from keyframes ``(frame, cx, bottom, w, h)``, linear in between, absent
    outside the first..last keyframe. Returns cxcywh (F, 4) and exists (F,)."""
    k = np.asarray(keys, dtype=np.float64)
    t = np.arange(n_frames, dtype=np.float64)
    cx, bottom, w, h = (np.interp(t, k[:, 0], k[:, j]) for j in range(1, 5))
    return np.stack([cx, bottom - h / 2, w, h], axis=1), (t >= k[0, 0]) & (t <= k[-1, 0])


class _RenderOptions(TypedDict):
    """The keyword arguments of :func:`_render` that a hand-made scene passes through."""

    width: int
    height: int
    fps: float
    occlusion_threshold: float
    miss_rate: float
    false_positive_rate: float
    noise_px: float


def _scene_from_keys(
    objects: Sequence[tuple[int, Sequence[Sequence[float]]]],
    n_frames: int,
    name: str,
    rng: np.random.Generator,
    **render: Unpack[_RenderOptions],
) -> SyntheticScene:
    parts = [_keyframed(n_frames, keys) for _, keys in objects]
    cxcywh = np.stack([p[0] for p in parts], axis=1)
    exists = np.stack([p[1] for p in parts], axis=1)
    class_id = np.array([cls for cls, _ in objects], dtype=np.int64)
    return _render(cxcywh, exists, class_id, rng=rng, name=name, **render)


def crossing_scene(
    seed: int = 0,
    *,
    gap: int = 8,
    far_speed: float = 8.0,
    direction: int = 1,
    near_class: int = CLASS_IDS["pedestrian"],
    far_class: int = CLASS_IDS["pedestrian"],
    n_frames: int | None = None,
    width: int = 1242,
    height: int = 375,
    fps: float = 10.0,
    occlusion_threshold: float = 0.6,
    miss_rate: float = 0.0,
    false_positive_rate: float = 0.0,
    noise_px: float = 1.0,
) -> SyntheticScene:
    """Two objects on straight horizontal paths, the far one (id 1) passing behind the near
    one (id 2), whose detections are dropped for exactly ``gap`` consecutive frames.

    The far object moves at ``direction * far_speed`` px/frame; the near one moves relative to
    it at the speed that makes the occlusion last ``gap`` frames, against ``direction``: if
    ``far_speed`` exceeds that relative speed the far object overtakes the near one from
    behind, otherwise they walk towards each other. Sizes, depths and the crossing point are
    jittered by ``seed``. With the defaults (two pedestrians, 8 px/frame) the far pedestrian
    reappears more than a box width from where it vanished, next to the near one: matching by
    IoU with the last box gives it a new id, or the near one's.

    ``n_frames`` defaults to 8 frames of clear view before the two first touch and after they
    separate. Raises ValueError if the near object cannot hide the far one (too small or too
    low in the image for ``occlusion_threshold``).
    """
    if gap < 1:
        raise ValueError(f"gap must be >= 1, got {gap}")
    if direction not in (-1, 1):
        raise ValueError(f"direction must be +1 or -1, got {direction}")
    _check_rates(occlusion_threshold, miss_rate, false_positive_rate, noise_px)
    rng = np.random.default_rng(seed)
    h_a = _HEIGHT.get(near_class, 90.0) * rng.uniform(0.95, 1.05)
    h_b = _HEIGHT.get(far_class, 90.0) * rng.uniform(0.85, 0.95)
    w_a = _ASPECT.get(near_class, 1.0) * h_a * rng.uniform(0.95, 1.05)
    w_b = _ASPECT.get(far_class, 1.0) * h_b * rng.uniform(0.95, 1.05)
    bot_a = height * rng.uniform(0.78, 0.84)
    bot_b = bot_a - rng.uniform(8.0, 16.0)
    # fraction of the far box's height behind the near box, and the x-overlap needed to hide it
    vertical = max(0.0, min(bot_a, bot_b) - max(bot_a - h_a, bot_b - h_b)) / h_b
    need = occlusion_threshold / vertical * w_b if vertical > 0 else math.inf
    if need >= min(w_a, w_b):
        raise ValueError("the near object is too small to hide the far one at this threshold")
    span = w_a + w_b - 2 * need  # range of centre offsets (px) during which it is hidden
    v_rel = span / gap
    v_b = direction * far_speed
    v_a = v_b - direction * v_rel
    approach = 0.5 * (w_a + w_b) / v_rel  # frames from first touch to the crossing
    if n_frames is None:
        n_frames = 2 * (math.ceil(approach) + 8) + 1
    # crossing at a half frame for even gaps so exactly `gap` whole frames are hidden
    t_c = n_frames // 2 + (0.5 if gap % 2 == 0 else 0.0)
    x_c = width / 2 + rng.uniform(-100.0, 100.0)
    t0, t1 = 0.0, float(n_frames - 1)

    def straight(v: float, bottom: float, w: float, h: float) -> list[list[float]]:
        return [[t0, x_c + v * (t0 - t_c), bottom, w, h], [t1, x_c + v * (t1 - t_c), bottom, w, h]]

    return _scene_from_keys(
        [
            (far_class, straight(v_b, bot_b, w_b, h_b)),
            (near_class, straight(v_a, bot_a, w_a, h_a)),
        ],
        n_frames,
        f"crossing_gap{gap}_seed{seed}",
        rng,
        width=width,
        height=height,
        fps=fps,
        occlusion_threshold=occlusion_threshold,
        miss_rate=miss_rate,
        false_positive_rate=false_positive_rate,
        noise_px=noise_px,
    )


def _turning_car_hides_cyclist(rng: np.random.Generator) -> SyntheticScene:
    """Figure 1 of the paper: the car ahead turns right across a cyclist riding ahead on its
    right; the cyclist is hidden while the car sweeps past, then reappears."""
    j = rng.uniform(-1.0, 1.0, 4)
    car, cyc = CLASS_IDS["car"], CLASS_IDS["cyclist"]
    n = 60
    car_keys = [  # straight ahead, then turning right: moving right, widening (side view)
        [0, 600 + 10 * j[0], 315, 175, 120],
        [15, 620 + 10 * j[0], 312, 180, 120],
        [28, 900, 302, 270, 116],
        [42, 1250, 295, 300, 112],
    ]
    cyc_keys = [  # riding forward (away): slowly shrinking, drifting up and right
        [0, 820 + 8 * j[1], 250, 48 * (1 + 0.03 * j[2]), 74 * (1 + 0.03 * j[2])],
        [n - 1, 860 + 8 * j[1], 240, 42 * (1 + 0.03 * j[2]), 64 * (1 + 0.03 * j[2])],
    ]
    oncoming = [[5, 420 + 5 * j[3], 200, 50, 30], [n - 1, 300 + 5 * j[3], 225, 80, 48]]
    return _scene_from_keys(
        [(cyc, cyc_keys), (car, car_keys), (car, oncoming)],
        n,
        "car_turns_right_hiding_cyclist",
        rng,
        **_SUITE_RENDER,
    )


def figure1_scene(seed: int = 0) -> SyntheticScene:
    """The paper's Figure 1 (used by ``sensemaking demo``): a car ahead turns right across a
    cyclist, who is hidden while the car sweeps past and then reappears; an oncoming car too."""
    return _turning_car_hides_cyclist(np.random.default_rng(seed))


def _turning_car_hides_car(rng: np.random.Generator) -> SyntheticScene:
    """The paper's anticipation example: a car turning left hides an oncoming car, which
    reappears nearer (larger, lower in the image) in front of the ego vehicle."""
    j = rng.uniform(-1.0, 1.0, 3)
    car = CLASS_IDS["car"]
    n = 50
    turning = [  # from the right, turning left across the road: moving left, widening
        [0, 1000 + 10 * j[0], 300, 160, 110],
        [10, 900 + 10 * j[0], 298, 200, 110],
        [30, 450, 292, 300, 105],
        [n - 1, 100, 290, 300, 100],
    ]
    oncoming = [  # approaching: growing, moving down and slightly left
        [0, 700 + 6 * j[1], 205, 70 * (1 + 0.03 * j[2]), 42 * (1 + 0.03 * j[2])],
        [n - 1, 560 + 6 * j[1], 262, 135 * (1 + 0.03 * j[2]), 80 * (1 + 0.03 * j[2])],
    ]
    return _scene_from_keys(
        [(car, oncoming), (car, turning)], n, "car_turns_left_hiding_car", rng, **_SUITE_RENDER
    )


def _leave_and_enter(rng: np.random.Generator) -> SyntheticScene:
    """A pedestrian leaves at the right border; soon after a different one enters there walking
    back, and a car enters at the left border. Nobody is occluded: the test is not to give the
    newcomer the old id."""
    j = rng.uniform(-1.0, 1.0, 3)
    ped, car = CLASS_IDS["pedestrian"], CLASS_IDS["car"]
    n = 50
    leaving = [[0, 1080 + 10 * j[0], 300, 44, 108], [25, 1080 + 10 * j[0] + 25 * 8, 300, 44, 108]]
    entering = [
        [22, 1262, 296 + 4 * j[1], 42, 104],
        [n - 1, 1262 - 27 * 7, 296 + 4 * j[1], 42, 104],
    ]
    car_keys = [[10, -60, 260 + 5 * j[2], 130, 76], [n - 1, -60 + 39 * 9, 262 + 5 * j[2], 136, 80]]
    return _scene_from_keys(
        [(ped, leaving), (ped, entering), (car, car_keys)],
        n,
        "leave_and_enter_at_border",
        rng,
        **_SUITE_RENDER,
    )


_SUITE_RENDER: _RenderOptions = {
    "width": 1242,
    "height": 375,
    "fps": 10.0,
    "occlusion_threshold": 0.6,
    "miss_rate": 0.0,
    "false_positive_rate": 0.0,
    "noise_px": 1.0,
}


class _CrossingOptions(TypedDict, total=False):
    """Keyword arguments of :func:`crossing_scene` that the suite varies."""

    gap: int
    far_speed: float
    direction: int
    near_class: int
    far_class: int


def occlusion_suite(seed: int = 0) -> list[SyntheticScene]:
    """Varied small occlusion scenes (speeds, gaps of 3-15 frames, directions, turning
    vehicles, leaving/entering at the border), each with a descriptive ``name``."""
    car, ped, truck, cyc = (CLASS_IDS[k] for k in ("car", "pedestrian", "truck", "cyclist"))
    rng = np.random.default_rng(seed)
    seeds = rng.integers(0, 2**31 - 1, 9)
    specs: list[tuple[str, _CrossingOptions]] = [
        ("pedestrian_overtakes_behind", dict(gap=8, far_speed=8.0, direction=1)),
        ("pedestrians_cross", dict(gap=4, far_speed=3.0, direction=-1)),
        (
            "car_overtakes_behind_car_long_gap",
            dict(gap=12, far_speed=14.0, direction=-1, near_class=car, far_class=car),
        ),
        (
            "car_crosses_behind_truck_gap15",
            dict(gap=15, far_speed=3.0, direction=1, near_class=truck, far_class=car),
        ),
        (
            "fast_cars_cross_gap3",
            dict(gap=3, far_speed=20.0, direction=1, near_class=car, far_class=car),
        ),
        (
            "cyclist_behind_van_gap6",
            dict(gap=6, far_speed=10.0, direction=-1, near_class=CLASS_IDS["van"], far_class=cyc),
        ),
    ]
    scenes = []
    for (name, kwargs), s in zip(specs, seeds[:6], strict=True):
        scene = crossing_scene(int(s), **kwargs)
        scenes.append(
            SyntheticScene(
                scene.detections,
                scene.ground_truth,
                scene.width,
                scene.height,
                scene.fps,
                scene.n_frames,
                name=name,
            )
        )
    scenes.append(_turning_car_hides_cyclist(np.random.default_rng(int(seeds[6]))))
    scenes.append(_turning_car_hides_car(np.random.default_rng(int(seeds[7]))))
    scenes.append(_leave_and_enter(np.random.default_rng(int(seeds[8]))))
    return scenes

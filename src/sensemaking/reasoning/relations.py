"""Qualitative spatial relations and motion, vectorised over pairs of boxes.

* Interval algebra (Allen): the 13 relations between two intervals on one axis, with a pixel
  tolerance under which two end points count as equal (so ``meets`` and ``equal`` survive
  detector jitter). For any two intervals and any tolerance exactly one relation holds.
* Rectangle algebra: the pair (x relation, y relation) between two axis-aligned boxes. Image
  y grows downwards, so on the y axis ``before`` means "above".
* Qualitative motion of a box between two frames: approaching / receding (the box grows /
  shrinks and its bottom edge moves down / up the image), moving left / right, stopped, and
  stopping (moving before, stopped now), looming (growing fast: a short time to contact) and
  keeping distance (neither growing nor shrinking);
  thresholds in pixels per second, so the same thresholds work at any frame rate.

* Depth order of a pair (:func:`pair_front`): which box is in front, by
  :func:`sensemaking.geometry.in_front` -- the one definition the tracker's occlusion facts
  use too (3D depth where both boxes have one, else box bottom, never in front of a box cut by
  the image border).

All of it is computed in numpy and handed to clingo as facts, and only for pairs that matter
(:func:`near_pairs`: boxes that overlap or lie within a gap proportional to their size).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from sensemaking.geometry import cut_by_border, in_front

__all__ = [
    "IA_RELATIONS",
    "INVERSE",
    "MOTION_KINDS",
    "RelationConfig",
    "MotionThresholds",
    "MotionFeatures",
    "interval_relation_masks",
    "interval_relations",
    "rectangle_relations",
    "inverse_codes",
    "relation_name",
    "near_pairs",
    "pair_relations",
    "order_pairs",
    "motion_features",
    "classify_motion",
    "track_motion",
    "relation_facts",
    "motion_facts",
    "pair_front",
    "BORDER_MARGIN_PX",
]

#: the 13 Allen relations; the index is the relation's integer code
IA_RELATIONS: tuple[str, ...] = (
    "before",
    "after",
    "during",
    "contains",
    "starts",
    "started_by",
    "finishes",
    "finished_by",
    "overlaps",
    "overlapped_by",
    "meets",
    "met_by",
    "equal",
)
_CODE = {name: i for i, name in enumerate(IA_RELATIONS)}
#: converse of each relation: ``r(a, b)`` iff ``INVERSE[r](b, a)``
INVERSE: dict[str, str] = {
    "before": "after",
    "after": "before",
    "during": "contains",
    "contains": "during",
    "starts": "started_by",
    "started_by": "starts",
    "finishes": "finished_by",
    "finished_by": "finishes",
    "overlaps": "overlapped_by",
    "overlapped_by": "overlaps",
    "meets": "met_by",
    "met_by": "meets",
    "equal": "equal",
}
_INVERSE_CODE = np.array([_CODE[INVERSE[r]] for r in IA_RELATIONS], dtype=np.int8)

#: qualitative motion kinds, the column order of :func:`classify_motion`
MOTION_KINDS: tuple[str, ...] = (
    "approaching",
    "receding",
    "moving_left",
    "moving_right",
    "stopped",
    "stopping",
    "looming",
    "keeping_distance",
)


def _cmp(x: np.ndarray, y: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """-1 / 0 / +1 where ``x`` is below / within ``tol`` of / above ``y`` (antisymmetric)."""
    d = x - y
    return np.where(d < -tol, -1, np.where(d > tol, 1, 0)).astype(np.int8)


def interval_relation_masks(
    a: np.ndarray, b: np.ndarray, tol: float | np.ndarray = 0.0
) -> np.ndarray:
    """(13, N) bool: which Allen relation holds between intervals ``a[i]`` and ``b[i]``.

    Args:
        a, b: (N, 2) intervals ``[lo, hi]`` (lo <= hi), any unit (pixels here).
        tol: scalar or (N,) tolerance >= 0 in the same unit: end points closer than ``tol``
            count as equal. With ``tol = 0`` these are Allen's exact definitions.

    Exactly one row is True in every column (also for degenerate intervals and large
    tolerances): ``equal`` takes precedence, then before/meets/after/met_by, then the eight
    relations of properly overlapping intervals.
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    if a.shape != b.shape:
        raise ValueError(f"interval arrays must have equal shapes, got {a.shape} and {b.shape}")
    if np.any(a[:, 0] > a[:, 1]) or np.any(b[:, 0] > b[:, 1]):
        raise ValueError("intervals must satisfy lo <= hi")
    t = np.broadcast_to(np.asarray(tol, dtype=np.float64), (a.shape[0],))
    if np.any(t < 0):
        raise ValueError("tolerance must be >= 0")
    s = _cmp(a[:, 0], b[:, 0], t)  # start vs start
    e = _cmp(a[:, 1], b[:, 1], t)  # end vs end
    p = _cmp(a[:, 1], b[:, 0], t)  # end of a vs start of b
    q = _cmp(a[:, 0], b[:, 1], t)  # start of a vs end of b
    return _masks_from_cmp(s, e, p, q)


def _masks_from_cmp(s: np.ndarray, e: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(13, N) relation masks from the four end-point comparisons (each -1 / 0 / +1)."""
    equal = (s == 0) & (e == 0)
    other = ~equal
    inside = other & (p == 1) & (q == -1)  # the intervals overlap by more than tol
    masks = {
        "before": other & (p == -1),
        "after": other & (q == 1),
        "meets": other & (p == 0),
        "met_by": other & (q == 0),
        "during": inside & (s == 1) & (e == -1),
        "contains": inside & (s == -1) & (e == 1),
        "starts": inside & (s == 0) & (e == -1),
        "started_by": inside & (s == 0) & (e == 1),
        "finishes": inside & (s == 1) & (e == 0),
        "finished_by": inside & (s == -1) & (e == 0),
        "overlaps": inside & (s == -1) & (e == -1),
        "overlapped_by": inside & (s == 1) & (e == 1),
        "equal": equal,
    }
    return np.stack([masks[r] for r in IA_RELATIONS])


@lru_cache(maxsize=1)
def _code_table() -> np.ndarray:
    """(81,) relation code for each end-point comparison pattern ``(s, e, p, q)`` in {-1, 0, 1}^4,
    derived from :func:`interval_relation_masks` so both always agree."""
    table = np.zeros(81, dtype=np.int8)
    for s in (-1, 0, 1):
        for e in (-1, 0, 1):
            for p in (-1, 0, 1):
                for q in (-1, 0, 1):
                    masks = _masks_from_cmp(*(np.array([v], dtype=np.int8) for v in (s, e, p, q)))
                    table[(s + 1) * 27 + (e + 1) * 9 + (p + 1) * 3 + (q + 1)] = int(
                        np.argmax(masks[:, 0])
                    )
    return table


_WEIGHTS = np.array([27, 9, 3, 1], dtype=np.int64)
#: end points compared by :func:`_codes`, per axis: start-start, end-end, end of a - start of b,
#: start of a - end of b (columns of an interval ``[lo, hi]``, and of a box on x then y)
_IA_A, _IA_B = np.array([0, 1, 1, 0]), np.array([0, 1, 0, 1])
_RA_A, _RA_B = np.array([0, 2, 2, 0, 1, 3, 3, 1]), np.array([0, 2, 0, 2, 1, 3, 1, 3])


def _codes(d: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """Relation codes from end-point differences ``d`` (..., 4) (order of :data:`_IA_A`) and
    tolerances broadcastable to ``d``: each difference is -1 / 0 / +1 beyond ``tol``."""
    c = (d > tol).astype(np.int64) - (d < -tol) + 1
    return _code_table()[c @ _WEIGHTS]


def interval_relations(a: np.ndarray, b: np.ndarray, tol: float | np.ndarray = 0.0) -> np.ndarray:
    """(N,) int8 codes (indices into :data:`IA_RELATIONS`) of the relation of ``a[i]`` to ``b[i]``.

    Same result as ``argmax(interval_relation_masks(a, b, tol))``, through a lookup table.
    Intervals must satisfy lo <= hi (not checked here).
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    t = np.asarray(tol, dtype=np.float64)
    return _codes(a.take(_IA_A, axis=1) - b.take(_IA_B, axis=1), t[:, None] if t.ndim == 1 else t)


def rectangle_relations(a: np.ndarray, b: np.ndarray, tol: float | np.ndarray = 0.0) -> np.ndarray:
    """(N, 2) int8 codes: rectangle-algebra relation (x, y) of box ``a[i]`` to box ``b[i]``.

    Args:
        a, b: (N, 4) boxes ``x1, y1, x2, y2`` in pixels.
        tol: scalar, (N,) or (N, 2) per-axis tolerance in pixels.
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    n = a.shape[0]
    t = np.asarray(tol, dtype=np.float64)
    if t.shape != (n, 2):
        t = np.broadcast_to(t[:, None] if t.ndim == 1 else t, (n, 2))
    # both axes at once: (N, 2 axes, 4 end-point differences)
    return _codes((a.take(_RA_A, axis=1) - b.take(_RA_B, axis=1)).reshape(n, 2, 4), t[:, :, None])


def inverse_codes(codes: np.ndarray) -> np.ndarray:
    """Codes of the converse relations (same shape)."""
    return _INVERSE_CODE[np.asarray(codes, dtype=np.int64)]


def relation_name(code: int) -> str:
    """Name of a relation code."""
    return IA_RELATIONS[int(code)]


@dataclass(frozen=True)
class RelationConfig:
    """Which pairs get relations, and the tolerance of ``meets`` / ``equal``.

    Attributes:
        near: a pair matters when the boxes overlap, or the gap between them on each axis is at
            most ``near`` times the larger box's size on that axis (fraction, >= 0).
        tol_px: end points within this many pixels count as equal (at least).
        tol_rel: ... or within this fraction of the smaller box's size on that axis, if larger.
    """

    near: float = 0.5
    tol_px: float = 3.0
    tol_rel: float = 0.05

    def __post_init__(self) -> None:
        if self.near < 0 or self.tol_px < 0 or self.tol_rel < 0:
            raise ValueError("RelationConfig values must be >= 0")


def near_pairs(xyxy: np.ndarray, near: float = 0.5) -> np.ndarray:
    """(P, 2) index pairs ``i < j`` of boxes that overlap or are within the ``near`` gap.

    Args:
        xyxy: (N, 4) boxes in pixels.
        near: allowed gap on each axis as a fraction of the larger box's size on that axis.
    """
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    n = x.shape[0]
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    w = x[:, 2] - x[:, 0]
    h = x[:, 3] - x[:, 1]
    gap_x = np.maximum(x[None, :, 0] - x[:, None, 2], x[:, None, 0] - x[None, :, 2])
    gap_y = np.maximum(x[None, :, 1] - x[:, None, 3], x[:, None, 1] - x[None, :, 3])
    ok = (gap_x <= near * np.maximum(w[:, None], w[None, :])) & (
        gap_y <= near * np.maximum(h[:, None], h[None, :])
    )
    i, j = np.nonzero(ok & _upper(n))
    out = np.empty((i.shape[0], 2), dtype=np.int64)
    out[:, 0], out[:, 1] = i, j
    return out


@lru_cache(maxsize=64)
def _upper(n: int) -> np.ndarray:
    """(n, n) bool, True above the diagonal (``i < j``); cached, do not modify."""
    return np.triu(np.ones((n, n), dtype=bool), 1)


def pair_relations(
    xyxy: np.ndarray, config: RelationConfig | None = None, pairs: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Rectangle relations of the pairs that matter.

    Args:
        xyxy: (N, 4) boxes in pixels.
        config: :class:`RelationConfig` (nearness and tolerances).
        pairs: (P, 2) index pairs to use instead of :func:`near_pairs`.

    Returns:
        ``pairs`` (P, 2) indices into ``xyxy`` and ``codes`` (P, 2) int8 (x, y) relation codes
        of box ``pairs[:, 0]`` to box ``pairs[:, 1]``.
    """
    c = config or RelationConfig()
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    if pairs is None:
        pairs = near_pairs(x, c.near)
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if pairs.shape[0] == 0:
        return pairs, np.zeros((0, 2), dtype=np.int8)
    a, b = x.take(pairs[:, 0], axis=0), x.take(pairs[:, 1], axis=0)
    size = np.minimum(a[:, 2:] - a[:, :2], b[:, 2:] - b[:, :2])  # (P, 2) smaller w, h
    tol = np.maximum(c.tol_px, c.tol_rel * size)
    return pairs, rectangle_relations(a, b, tol)


# -- motion -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class MotionThresholds:
    """Thresholds of qualitative motion, in pixels per second (``fps`` converts frames).

    Attributes:
        lag_s: motion is measured between a frame and the one ``lag_s`` seconds before
            (at least one frame): longer is smoother, shorter reacts faster.
        lateral_px_s: horizontal speed of the box centre above which it is moving left/right.
        bottom_px_s: vertical speed of the bottom edge needed for approaching / receding.
        growth_s: relative growth of the box height per second (1/s) needed for approaching
            (``+growth_s``) or receding (``-growth_s``); below it in magnitude the box is
            keeping its distance.
        stopped_px_s: centre speed below which the box is stopped (and its growth below
            ``growth_s``).
        moving_px_s: centre speed above which a box counts as moving, for ``stopping``: moving
            ``lag_s`` before, stopped now.
        looming_s: relative growth of the box height per second (1/s) from which it is looming:
            approaching with a time to contact below ``1 / looming_s`` seconds.
    """

    lag_s: float = 0.3
    lateral_px_s: float = 20.0
    bottom_px_s: float = 5.0
    growth_s: float = 0.1
    stopped_px_s: float = 10.0
    moving_px_s: float = 40.0
    looming_s: float = 0.5

    def __post_init__(self) -> None:
        if self.lag_s <= 0:
            raise ValueError("lag_s must be positive")
        if self.stopped_px_s >= self.moving_px_s:
            raise ValueError("stopped_px_s must be below moving_px_s")
        if self.looming_s <= self.growth_s:
            raise ValueError("looming_s must exceed growth_s")

    def lag_frames(self, fps: float) -> int:
        """The lag in whole frames (>= 1) at ``fps`` frames per second."""
        return max(1, int(round(self.lag_s * fps)))


@dataclass(frozen=True)
class MotionFeatures:
    """Per-box velocities between two frames, all (N,) float64.

    Attributes:
        vx: centre x velocity, px/s (positive: moving right).
        vy: centre y velocity, px/s (positive: moving down the image).
        vbottom: bottom edge velocity, px/s (positive: down the image, i.e. nearer).
        growth: relative growth rate of the box height, 1/s (positive: getting larger).
        speed: centre speed, px/s.
    """

    vx: np.ndarray
    vy: np.ndarray
    vbottom: np.ndarray
    growth: np.ndarray
    speed: np.ndarray


def motion_features(prev: np.ndarray, cur: np.ndarray, dt: float | np.ndarray) -> MotionFeatures:
    """Velocities of boxes from ``prev`` (N, 4) to ``cur`` (N, 4), ``dt`` seconds apart (scalar or
    (N,))."""
    p = np.asarray(prev, dtype=np.float64).reshape(-1, 4)
    c = np.asarray(cur, dtype=np.float64).reshape(-1, 4)
    dt = np.asarray(dt, dtype=np.float64)
    if dt.shape != (p.shape[0],):
        dt = np.broadcast_to(dt, (p.shape[0],))
    if np.any(dt <= 0):
        raise ValueError("dt must be positive")
    v = ((c[:, :2] + c[:, 2:]) - (p[:, :2] + p[:, 2:])) / 2 / dt[:, None]  # centre vx, vy
    vbottom = (c[:, 3] - p[:, 3]) / dt
    hp = np.maximum(p[:, 3] - p[:, 1], 1e-6)
    hc = np.maximum(c[:, 3] - c[:, 1], 1e-6)
    growth = (hc - hp) / (0.5 * (hp + hc)) / dt
    vx, vy = v[:, 0], v[:, 1]
    # sqrt(vx² + vy²), not hypot: the value the thresholds were set on (hypot's last bit varies)
    return MotionFeatures(vx, vy, vbottom, growth, np.sqrt(vx * vx + vy * vy))


def classify_motion(
    now: MotionFeatures,
    speed_before: np.ndarray | None = None,
    thresholds: MotionThresholds | None = None,
) -> np.ndarray:
    """(N, 8) bool, columns :data:`MOTION_KINDS`.

    Args:
        now: features over the last lag.
        speed_before: (N,) centre speed (px/s) over the lag before that, NaN where unknown;
            needed for ``stopping``.
        thresholds: :class:`MotionThresholds`.
    """
    t = thresholds or MotionThresholds()
    n = now.vx.shape[0]
    approaching = (now.growth >= t.growth_s) & (now.vbottom >= t.bottom_px_s)
    receding = (now.growth <= -t.growth_s) & (now.vbottom <= -t.bottom_px_s)
    left = now.vx <= -t.lateral_px_s
    right = now.vx >= t.lateral_px_s
    stopped = (now.speed < t.stopped_px_s) & (np.abs(now.growth) < t.growth_s)
    if speed_before is None:
        stopping = np.zeros(n, dtype=bool)
    else:
        before = np.asarray(speed_before, dtype=np.float64).reshape(n)
        with np.errstate(invalid="ignore"):
            stopping = stopped & (before >= t.moving_px_s)
    out = np.empty((n, len(MOTION_KINDS)), dtype=bool)
    out[:, 0], out[:, 1], out[:, 2], out[:, 3] = approaching, receding, left, right
    out[:, 4], out[:, 5] = stopped, stopping
    out[:, 6] = approaching & (now.growth >= t.looming_s)
    out[:, 7] = np.abs(now.growth) < t.growth_s
    return out


def track_motion(
    frames: np.ndarray, xyxy: np.ndarray, fps: float, thresholds: MotionThresholds | None = None
) -> tuple[np.ndarray, np.ndarray, MotionFeatures]:
    """Qualitative motion along one track.

    Args:
        frames: (K,) increasing frame numbers of the boxes (usually the visible ones only).
        xyxy: (K, 4) boxes in pixels. fps: frames per second.
        thresholds: :class:`MotionThresholds`.

    Returns:
        ``frames`` (M,) where a box ``lag`` to ``2 lag`` frames earlier exists, ``kinds`` (M, 8)
        bool (columns :data:`MOTION_KINDS`) and the :class:`MotionFeatures` (arrays of M).
    """
    t = thresholds or MotionThresholds()
    f = np.asarray(frames, dtype=np.int64).reshape(-1)
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    lag = t.lag_frames(fps)
    j = np.searchsorted(f, f - lag, side="right") - 1  # last box at least `lag` frames earlier
    jj = np.maximum(j, 0)
    ok = (j >= 0) & (f - f[jj] <= 2 * lag)
    idx = np.flatnonzero(ok)
    prev = jj[idx]
    feats = (
        motion_features(x[prev], x[idx], (f[idx] - f[prev]) / float(fps))
        if idx.size
        else MotionFeatures(*(np.zeros(0) for _ in range(5)))
    )
    speed = np.full(f.shape[0], np.nan)
    speed[idx] = feats.speed
    kinds = classify_motion(feats, speed[prev], t)
    return f[idx], kinds, feats


# -- facts ----------------------------------------------------------------------------------------
def order_pairs(
    ids: np.ndarray, pairs: np.ndarray, codes: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Id pairs with the smaller id first, codes converted where a pair was swapped.

    Args:
        ids: (N,) track ids. pairs: (P, 2) indices into ``ids``. codes: (P, 2) relation codes of
            ``pairs[:, 0]`` to ``pairs[:, 1]``.

    Returns:
        ``a`` (P,), ``b`` (P,) ids with ``a < b`` and (P, 2) codes of ``a`` to ``b``.
    """
    ids = np.asarray(ids, dtype=np.int64)
    a, b = ids[pairs[:, 0]], ids[pairs[:, 1]]
    swap = a > b
    codes = np.where(swap[:, None], inverse_codes(codes), codes).astype(np.int8)
    return np.where(swap, b, a), np.where(swap, a, b), codes


def relation_facts(
    frame: int,
    ids: np.ndarray,
    pairs: np.ndarray,
    codes: np.ndarray,
    front: np.ndarray | None = None,
) -> list[tuple[Any, ...]]:
    """``ra(A,B,F,Rx,Ry)`` facts (tuples, see :mod:`~sensemaking.reasoning.facts`), one per pair,
    with ``A < B``. The encoding ``relations.lp`` derives the converse ``ra(B,A,F,...)``; give
    each unordered pair once. With ``front`` (P,) (:func:`pair_front` of the same pairs), also
    ``front(A,B,F)``: A is in front of B (``relations.lp`` reads it as ``closer/3``).
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    ids = np.asarray(ids, dtype=np.int64)
    a, b, ordered = order_pairs(ids, pairs, codes)
    out: list[tuple[Any, ...]] = [
        ("ra", x, y, int(frame), IA_RELATIONS[rx], IA_RELATIONS[ry])
        for x, y, (rx, ry) in zip(a.tolist(), b.tolist(), ordered.tolist(), strict=True)
    ]
    if front is not None and len(pairs):
        f = np.asarray(front, dtype=np.int64)
        near = np.where(f > 0, pairs[:, 0], pairs[:, 1])[f != 0]
        far = np.where(f > 0, pairs[:, 1], pairs[:, 0])[f != 0]
        out += [
            ("front", x, y, int(frame))
            for x, y in zip(ids[near].tolist(), ids[far].tolist(), strict=True)
        ]
    return out


#: distance to the image border, pixels, within which a box counts as cut by it (the tracker's
#: default ``border_margin``)
BORDER_MARGIN_PX = 10.0


def pair_front(
    xyxy: np.ndarray,
    pairs: np.ndarray,
    depth: np.ndarray | None = None,
    image_size: tuple[int, int] | None = None,
    margin: float = BORDER_MARGIN_PX,
    config: RelationConfig | None = None,
) -> np.ndarray:
    """(P,) int8: +1 where box ``pairs[k, 0]`` is in front of box ``pairs[k, 1]``, -1 where it
    is behind, 0 where neither is known to be in front (:func:`sensemaking.geometry.in_front`).

    Args:
        xyxy: (N, 4) boxes in pixels. pairs: (P, 2) indices into them.
        depth: (N,) metres along the optical axis, NaN where unknown (``Detections.depth``).
        image_size: ``(width, height)``: boxes within ``margin`` pixels of its left, right or
            bottom border are cut (:func:`sensemaking.geometry.cut_by_border`); None: none is.
        config: its tolerances (``tol_px``, ``tol_rel``) are the margin beyond jitter: box
            bottoms closer than that are ``equal`` to the interval relations, and neither box
            is in front (as ``bottom_lower/1`` of the y relation says). The tracker's facts use
            no margin; so whatever is in front here is in front there too, never the reverse.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        return np.zeros(0, dtype=np.int8)
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    c = config or RelationConfig()
    front = in_front(
        x, depth, cut_by_border(x, image_size, margin), tol_px=c.tol_px, tol_rel=c.tol_rel
    )
    a, b = pairs[:, 0], pairs[:, 1]
    return (front[a, b].astype(np.int8) - front[b, a].astype(np.int8)).astype(np.int8)


def motion_facts(frame: int, ids: np.ndarray, kinds: np.ndarray) -> list[tuple[Any, ...]]:
    """``motion(T,F,Kind)`` facts (tuples) from (N, 8) bool :func:`classify_motion` output."""
    ids = np.asarray(ids, dtype=np.int64)
    rows, cols = np.nonzero(np.asarray(kinds, dtype=bool))
    return [
        ("motion", int(ids[r]), int(frame), MOTION_KINDS[k])
        for r, k in zip(rows.tolist(), cols.tolist(), strict=True)
    ]

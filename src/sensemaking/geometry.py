"""Batched box geometry on (N, 4) ``x1, y1, x2, y2`` arrays in pixels, and the one depth order
("in front of") that the tracker's occlusion facts and the scene's ``closer`` relation share."""

from __future__ import annotations

import numpy as np

__all__ = [
    "iou",
    "intersection",
    "coverage",
    "box_area",
    "safe_ratio",
    "iou_from_intersection",
    "xywh_to_xyxy",
    "xyxy_to_xywh",
    "xyxy_to_cxcywh",
    "cxcywh_to_xyxy",
    "clip_to_image",
    "cut_by_border",
    "front_margin",
    "in_front",
]


def intersection(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) intersection areas between boxes ``a`` (N, 4) and ``b`` (M, 4)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    w = np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0])
    h = np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1])
    # np.maximum, not np.clip: the same values, without clip's per-call overhead (hot per frame)
    return np.maximum(w, 0.0) * np.maximum(h, 0.0)


def box_area(x: np.ndarray) -> np.ndarray:
    """(N,) areas of (N, 4) ``xyxy`` boxes (0 for inverted boxes)."""
    return np.maximum(x[:, 2] - x[:, 0], 0.0) * np.maximum(x[:, 3] - x[:, 1], 0.0)


def safe_ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``num / den`` elementwise, 0 where ``den`` is not positive (broadcasting as ``/``)."""
    positive = den > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(positive, num / np.where(positive, den, 1.0), 0.0)


def iou_from_intersection(inter: np.ndarray, area_a: np.ndarray, area_b: np.ndarray) -> np.ndarray:
    """:func:`iou` from the (N, M) :func:`intersection` and the areas (N,), (M,) of the boxes
    (for callers that computed them already)."""
    return safe_ratio(inter, area_a[:, None] + area_b[None, :] - inter)


def iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) intersection over union in [0, 1]; 0 where the union is empty."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    return iou_from_intersection(intersection(a, b), box_area(a), box_area(b))


def coverage(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) fraction of each box of ``a`` covered by each box of ``b`` (intersection / area)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    return safe_ratio(intersection(a, b), box_area(a)[:, None])


def xywh_to_xyxy(xywh: np.ndarray) -> np.ndarray:
    """(N, 4) top-left + size -> corners."""
    out = np.array(xywh, dtype=np.float64).reshape(-1, 4)
    out[:, 2:] += out[:, :2]
    return out


def xyxy_to_xywh(xyxy: np.ndarray) -> np.ndarray:
    """(N, 4) corners -> top-left + size."""
    out = np.array(xyxy, dtype=np.float64).reshape(-1, 4)
    out[:, 2:] -= out[:, :2]
    return out


def xyxy_to_cxcywh(xyxy: np.ndarray) -> np.ndarray:
    """(N, 4) corners -> centre x, centre y, width, height."""
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    w = x[:, 2] - x[:, 0]
    h = x[:, 3] - x[:, 1]
    return np.stack([x[:, 0] + w / 2, x[:, 1] + h / 2, w, h], axis=1)


def cxcywh_to_xyxy(c: np.ndarray) -> np.ndarray:
    """(N, 4) centre x, centre y, width, height -> corners."""
    c = np.asarray(c, dtype=np.float64).reshape(-1, 4)
    hw, hh = c[:, 2] / 2, c[:, 3] / 2
    return np.stack([c[:, 0] - hw, c[:, 1] - hh, c[:, 0] + hw, c[:, 1] + hh], axis=1)


def clip_to_image(xyxy: np.ndarray, width: float, height: float) -> np.ndarray:
    """(N, 4) boxes clipped to the image ``[0, width] x [0, height]``."""
    out = np.array(xyxy, dtype=np.float64).reshape(-1, 4)
    out[:, [0, 2]] = np.clip(out[:, [0, 2]], 0.0, width)
    out[:, [1, 3]] = np.clip(out[:, [1, 3]], 0.0, height)
    return out


def cut_by_border(
    xyxy: np.ndarray, image_size: tuple[float, float] | None, margin: float = 0.0
) -> np.ndarray:
    """(N,) bool: the box reaches the left, right or bottom border of the ``(W, H)`` image
    (within ``margin`` pixels) -- where the object may go on beyond the image, so the box's
    bottom edge is only an upper bound of its foot point. The top border is not counted: it
    cuts the top of a box, never its bottom. All False without an image size."""
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    if image_size is None:
        return np.zeros(len(x), dtype=bool)
    w, h = float(image_size[0]), float(image_size[1])
    return (x[:, 0] <= margin) | (x[:, 2] >= w - margin) | (x[:, 3] >= h - margin)


def front_margin(
    front: np.ndarray, back: np.ndarray, depth_front: np.ndarray, depth_back: np.ndarray
) -> np.ndarray:
    """(K,) how far each ``front`` box stands in front of its ``back`` box, as a fraction:
    where both have a depth (metres), the depth gap over the back one's depth; else the gap of
    the box bottoms over the back box's height (pixels over pixels). Rows are pairs: (K, 4)
    boxes, (K,) depths, NaN where unknown. The evidence of :func:`in_front`'s order: near 0 the
    two could as well stand side by side."""
    f = np.asarray(front, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(back, dtype=np.float64).reshape(-1, 4)
    zf, zb = np.asarray(depth_front, dtype=np.float64), np.asarray(depth_back, dtype=np.float64)
    by_box = (f[:, 3] - b[:, 3]) / np.maximum(b[:, 3] - b[:, 1], 1e-9)
    both = np.isfinite(zf) & np.isfinite(zb) & (zb > 0)
    by_depth = np.where(both, (zb - zf) / np.where(both, zb, 1.0), 0.0)
    return np.where(both, by_depth, by_box)


def in_front(
    xyxy: np.ndarray,
    depth: np.ndarray | None = None,
    cut: np.ndarray | None = None,
    rows: int | None = None,
    tol_px: float = 0.0,
    tol_rel: float = 0.0,
) -> np.ndarray:
    """(R, N) bool: box ``i`` (of the first ``rows``, default all N) is in front of box ``j``,
    i.e. nearer to the camera; never a box in front of itself.

    The order, fixed by geometry and not by any score:

    * both boxes have a depth (finite ``depth``, metres along the optical axis, e.g. a 3D
      detector's ``z``): ``i`` is in front iff it is nearer, ``depth[i] < (1 - tol_rel) *
      depth[j]``;
    * otherwise, on a flat ground plane seen from above, the box whose bottom edge is lower in
      the image stands nearer: ``y2[i] > y2[j] + max(tol_px, tol_rel * min(h[i], h[j]))`` --
      but only when ``j``'s bottom is known, i.e.
      ``j`` is not cut by the image border (``cut[j]``, :func:`cut_by_border`): a cut object
      may reach below its visible box, so nothing is in front of it by box bottom. A cut ``i``
      can still be in front: its true bottom is at least as low as the visible one.

    Args:
        xyxy: (N, 4) boxes in pixels.
        depth: (N,) depth in metres, NaN where unknown; None: no depths.
        cut: (N,) bool, the box is cut by the image border; None: no box is.
        rows: judge only the first ``rows`` boxes as the one in front (default N).
        tol_px, tol_rel: a margin beyond jitter, pixels and fraction (0: none, the tracker's
            facts). With a margin the order is stricter, never reversed: what is in front with
            a margin is in front without one.
    """
    x = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    n = len(x)
    r = n if rows is None else rows
    bottom = x[:, 3]
    if tol_px > 0 or tol_rel > 0:
        height = x[:, 3] - x[:, 1]
        tol = np.maximum(tol_px, tol_rel * np.minimum(height[:r, None], height[None, :]))
        front = bottom[:r, None] > bottom[None, :] + tol
    else:
        front = bottom[:r, None] > bottom[None, :]
    if cut is not None:
        front &= ~np.asarray(cut, dtype=bool)[None, :]
    if depth is not None:
        z = np.asarray(depth, dtype=np.float64)
        known = np.isfinite(z)
        if known.any():
            both = known[:r, None] & known[None, :]
            with np.errstate(invalid="ignore"):
                nearer = z[:r, None] < (1.0 - tol_rel) * z[None, :]
            front = np.where(both, nearer, front)
    return front

"""Scene context: the ego corridor, lanes and semantic segmentation. All optional but the
corridor (which has a default); reasoning works without lanes or segmentation, and the
situations that need them say so.

File formats
------------
**Lanes** (JSON, pixels of the image the boxes are in)::

    {"lanes": [
        {"id": 1, "points": [[x, y], ...], "width": 140},         # centre line, one width
        {"id": 2, "points": [[x, y], ...], "widths": [60, ...]},  # centre line, width per point
        {"id": "bus", "left": [[x, y], ...], "right": [[x, y], ...]}  # the two boundaries
     ],
     "frames": {"120": [ ...lanes as above... ], ...}}

``lanes`` apply to every frame; ``frames`` (optional) gives lanes for some frames, which then
hold until the next listed frame (annotate only when the lanes change). A lane id is an integer
or a string. Polylines need at least two points and are used over their vertical extent only
(a lane covers, at each image row, the x range between its boundaries; a centre line with
width ``w`` has boundaries ``x -/+ w/2``). Widths are in pixels, at least 1.

**Segmentation**: a label map per frame, ``<dir>/<frame>.npy`` (integer array (H, W)) or
``<dir>/<frame>.png`` (single channel; needs Pillow, else use .npy), the frame number zero-padded
to 6 digits (KITTI's ``000042.png``) or not; or one file used for every frame (static camera).
Label names come from ``<dir>/labels.json`` (``{"0": "road", "1": "sidewalk", ...}``) or the
``labels`` argument, by default the Cityscapes train ids (:data:`CITYSCAPES_LABELS`). A map of
another size than the image is scaled.

**Ego corridor**: a polygon in image coordinates, as fractions of the image size
(``normalized=True``, the default) or in pixels. The default is a trapezoid over the lower
middle of the image, ``(0.1, 1) (0.9, 1) (0.6, 0.5) (0.4, 0.5)``: on KITTI's camera geometry
roughly the ego lane and half of each neighbour lane, the region where a road user appearing
is a hazard. A box is *in the corridor* when at least ``min_overlap`` of its bottom edge (the
line where it stands on the road) lies inside the polygon's horizontal extent at that row.
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.errors import TOO_DEEP, InputError
from sensemaking.io.text import load_json, read_input_text

__all__ = [
    "Corridor",
    "Lane",
    "LaneMap",
    "Segmentation",
    "SceneContext",
    "CITYSCAPES_LABELS",
    "DEFAULT_CORRIDOR",
    "load_lanes",
    "asp_name",
]

log = logging.getLogger(__name__)

#: the default ego corridor, fractions of (width, height): bottom-left, bottom-right, top-right,
#: top-left
DEFAULT_CORRIDOR: tuple[tuple[float, float], ...] = (
    (0.1, 1.0),
    (0.9, 1.0),
    (0.6, 0.5),
    (0.4, 0.5),
)

#: Cityscapes train ids -> names (the usual output of road-scene segmentation models)
CITYSCAPES_LABELS: dict[int, str] = {
    0: "road",
    1: "sidewalk",
    2: "building",
    3: "wall",
    4: "fence",
    5: "pole",
    6: "traffic_light",
    7: "traffic_sign",
    8: "vegetation",
    9: "terrain",
    10: "sky",
    11: "person",
    12: "rider",
    13: "car",
    14: "truck",
    15: "bus",
    16: "train",
    17: "motorcycle",
    18: "bicycle",
    255: "void",
}


@lru_cache(maxsize=1024)  # called per track and frame by the situation monitor
def asp_name(text: str) -> str:
    """A clingo constant from a label name: lower case, ``[a-z0-9_]``, starting with a letter."""
    s = re.sub(r"[^a-z0-9_]+", "_", str(text).strip().lower()).strip("_")
    return s if s and s[0].isalpha() else f"l_{s}" if s else "unknown"


def _spans(poly: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal extent (xl, xr) of polygon ``poly`` (K, 2) at rows ``y`` (N,); NaN outside."""
    p0 = poly
    p1 = np.roll(poly, -1, axis=0)
    y0, y1, x0, x1 = p0[:, 1], p1[:, 1], p0[:, 0], p1[:, 0]
    yy = y[:, None]
    inside = (yy >= np.minimum(y0, y1)) & (yy <= np.maximum(y0, y1))
    flat = y1 == y0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(flat, 0.0, (yy - y0) / np.where(flat, 1.0, y1 - y0))
    xs = x0 + t * (x1 - x0)
    lo = np.where(flat, np.minimum(x0, x1), xs)
    hi = np.where(flat, np.maximum(x0, x1), xs)
    xl = np.where(inside, lo, np.inf).min(axis=1)
    xr = np.where(inside, hi, -np.inf).max(axis=1)
    bad = ~np.isfinite(xl)
    return np.where(bad, np.nan, xl), np.where(bad, np.nan, xr)


@lru_cache(maxsize=64)
def _profile(
    points: tuple[tuple[float, float], ...], normalized: bool, image_size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of the polygon's vertices (sorted) and its x extent there: between two such rows
    the extent of a convex polygon is linear in y, so np.interp over them is exact (for other
    polygons it is an approximation between vertex rows)."""
    p = np.asarray(points, dtype=np.float64)
    if normalized:
        p = p * np.asarray(image_size, dtype=np.float64)
    ys = np.unique(p[:, 1])
    xl, xr = _spans(p, ys)
    return ys, xl, xr


def _edge_ratio(xyxy: np.ndarray, xl: np.ndarray, xr: np.ndarray) -> np.ndarray:
    """Length of ``[xl, xr]`` within each box's bottom edge over the edge's length, unclipped
    (negative for a gap, NaN where ``xl``/``xr`` are NaN)."""
    w = np.maximum(xyxy[:, 2] - xyxy[:, 0], 1e-9)
    return (np.minimum(xyxy[:, 2], xr) - np.maximum(xyxy[:, 0], xl)) / w


def _edge_overlap(xyxy: np.ndarray, xl: np.ndarray, xr: np.ndarray) -> np.ndarray:
    """Fraction of each box's bottom edge inside ``[xl, xr]`` (0 where NaN)."""
    out = np.clip(_edge_ratio(xyxy, xl, xr), 0.0, 1.0)
    return np.where(np.isnan(out), 0.0, out)


@dataclass(frozen=True)
class Corridor:
    """The region in front of the ego vehicle, a polygon in image coordinates.

    Attributes:
        points: polygon vertices ``(x, y)``, in order (convex: the horizontal extent at each row
            is used, exact for convex polygons).
        normalized: points are fractions of the image size (True) or pixels (False).
        min_overlap: fraction of a box's bottom edge that must lie in the corridor (0, 1].
    """

    points: tuple[tuple[float, float], ...] = DEFAULT_CORRIDOR
    normalized: bool = True
    min_overlap: float = 0.5

    def __post_init__(self) -> None:
        pts = tuple((float(x), float(y)) for x, y in self.points)
        if len(pts) < 3:
            raise ValueError("a corridor polygon needs at least 3 points")
        if not 0 < self.min_overlap <= 1:
            raise ValueError("min_overlap must lie in (0, 1]")
        object.__setattr__(self, "points", pts)

    def polygon(self, image_size: tuple[int, int]) -> np.ndarray:
        """(K, 2) vertices in pixels for an image of ``image_size = (width, height)``."""
        p = np.asarray(self.points, dtype=np.float64)
        return p * np.asarray(image_size, dtype=np.float64) if self.normalized else p

    def span_at(self, y: np.ndarray, image_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Corridor x range ``(xl, xr)`` (N,) at image rows ``y`` (N,) in pixels; NaN outside."""
        y = np.asarray(y, dtype=np.float64).reshape(-1)
        size = (int(image_size[0]), int(image_size[1]))
        ys, left, right = _profile(self.points, self.normalized, size)
        out = (y < ys[0]) | (y > ys[-1])
        return np.where(out, np.nan, np.interp(y, ys, left)), np.where(
            out, np.nan, np.interp(y, ys, right)
        )

    def overlap(self, xyxy: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
        """(N,) fraction of each box's bottom edge inside the corridor."""
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        xl, xr = self.span_at(b[:, 3], image_size)
        return _edge_overlap(b, xl, xr)

    def contains_boxes(self, xyxy: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
        """(N,) bool: the box stands in the corridor (``overlap >= min_overlap``)."""
        # min_overlap is in (0, 1]: clipping the ratio to [0, 1] and NaN -> 0 change nothing here
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        return _edge_ratio(b, *self.span_at(b[:, 3], image_size)) >= self.min_overlap

    def contains_points(self, points: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
        """(N,) bool: points ``(x, y)`` in pixels lie inside the corridor."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        xl, xr = self.span_at(p[:, 1], image_size)
        with np.errstate(invalid="ignore"):
            return (p[:, 0] >= xl) & (p[:, 0] <= xr)

    def to_json(self) -> dict[str, Any]:
        return {
            "points": [list(p) for p in self.points],
            "normalized": self.normalized,
            "min_overlap": self.min_overlap,
        }

    @classmethod
    def from_json(cls, record: Mapping[str, Any]) -> Corridor:
        return cls(
            tuple(tuple(p) for p in record["points"]),
            bool(record.get("normalized", True)),
            float(record.get("min_overlap", 0.5)),
        )

    @classmethod
    def parse(cls, text: str) -> Corridor:
        """From ``"x,y x,y x,y ..."`` (or all numbers comma-separated); fractions of the image
        size when every number is within [0, 1], else pixels. Raises InputError."""
        nums = [float(v) for v in re.split(r"[\s,;]+", text.strip()) if v]
        if len(nums) < 6 or len(nums) % 2:
            raise InputError(f"corridor needs at least 3 x,y points, got {text!r}")
        pts = tuple(zip(nums[0::2], nums[1::2], strict=True))
        return cls(pts, normalized=all(0.0 <= v <= 1.0 for v in nums))


@dataclass(frozen=True, eq=False)
class Lane:
    """One lane: its left and right boundary polylines, (K, 2) pixels, sorted by y."""

    id: int | str
    left: np.ndarray
    right: np.ndarray

    def span_at(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lane x range ``(xl, xr)`` (N,) at rows ``y`` (N,); NaN outside its vertical extent."""
        y = np.asarray(y, dtype=np.float64).reshape(-1)
        lo = max(self.left[0, 1], self.right[0, 1])
        hi = min(self.left[-1, 1], self.right[-1, 1])
        xl = np.interp(y, self.left[:, 1], self.left[:, 0])
        xr = np.interp(y, self.right[:, 1], self.right[:, 0])
        a, b = np.minimum(xl, xr), np.maximum(xl, xr)
        out = (y < lo) | (y > hi)
        return np.where(out, np.nan, a), np.where(out, np.nan, b)

    def contains_points(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: points ``(x, y)`` lie on the lane."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        xl, xr = self.span_at(p[:, 1])
        with np.errstate(invalid="ignore"):
            return (p[:, 0] >= xl) & (p[:, 0] <= xr)

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "left": self.left.tolist(), "right": self.right.tolist()}


def _polyline(value: Any, where: str, path: str | None) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{where}: points must be a list of [x, y] numbers", path) from None
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 2 or not np.isfinite(arr).all():
        raise InputError(f"{where}: need at least two [x, y] points, got shape {arr.shape}", path)
    return arr


def _sorted_by_y(arr: np.ndarray) -> np.ndarray:
    return arr[np.argsort(arr[:, 1], kind="stable")]


def _lane(record: Any, where: str, path: str | None) -> Lane:
    if not isinstance(record, Mapping):
        raise InputError(
            f"{where}: a lane must be an object with 'id' and 'points' or 'left'/'right'", path
        )
    lid = record.get("id")
    # an integer id is a clingo number: 32 bits
    if isinstance(lid, bool) or not (
        isinstance(lid, str) or (isinstance(lid, int) and -(2**31) <= lid < 2**31)
    ):
        raise InputError(
            f"{where}: lane 'id' must be an integer or a string, got {lid!r} (an integer is a "
            "clingo number: -2147483648..2147483647)",
            path,
        )
    if "left" in record or "right" in record:
        left = _sorted_by_y(_polyline(record.get("left"), f"{where} (left)", path))
        right = _sorted_by_y(_polyline(record.get("right"), f"{where} (right)", path))
        return Lane(lid, left, right)
    pts = _polyline(record.get("points"), where, path)
    if "widths" not in record and "width" not in record:
        raise InputError(f"{where}: a centre-line lane needs 'width' or 'widths' (pixels)", path)
    try:
        if "widths" in record:
            widths = np.asarray(record["widths"], dtype=np.float64).reshape(-1)
        else:
            widths = np.full(pts.shape[0], float(record["width"]))
    except (TypeError, ValueError):
        raise InputError(f"{where}: lane widths must be numbers (pixels)", path) from None
    if widths.shape[0] != pts.shape[0]:
        raise InputError(f"{where}: 'widths' needs one value per point ({pts.shape[0]})", path)
    if np.any(widths < 1) or not np.isfinite(widths).all():
        raise InputError(f"{where}: lane widths must be >= 1 pixel", path)
    order = np.argsort(pts[:, 1], kind="stable")
    pts, widths = pts[order], widths[order]
    half = widths[:, None] * np.array([[0.5, 0.0]])
    return Lane(lid, pts - half, pts + half)


@dataclass(frozen=True)
class LaneMap:
    """Lanes for a sequence: ``lanes`` for every frame, ``per_frame`` from a frame on."""

    lanes: tuple[Lane, ...] = ()
    per_frame: Mapping[int, tuple[Lane, ...]] = field(default_factory=dict)

    def lanes_at(self, frame: int) -> tuple[Lane, ...]:
        """The lanes in force at ``frame``: the last ``per_frame`` entry at or before it, else
        ``lanes``."""
        if self.per_frame:
            keys = [k for k in self.per_frame if k <= frame]
            if keys:
                return self.per_frame[max(keys)]
        return self.lanes

    def __bool__(self) -> bool:
        return bool(self.lanes) or any(self.per_frame.values())

    @classmethod
    def from_json(cls, record: Any, path: str | None = None) -> LaneMap:
        """From the lanes JSON (see the module docstring). Raises InputError."""
        if not isinstance(record, Mapping) or not ("lanes" in record or "frames" in record):
            raise InputError("lanes file must be an object with 'lanes' and/or 'frames'", path)
        lanes = record.get("lanes", [])
        if not isinstance(lanes, list):
            raise InputError("'lanes' must be a list", path)
        base = tuple(_lane(r, f"lanes[{i}]", path) for i, r in enumerate(lanes))
        frames = record.get("frames", {})
        if not isinstance(frames, Mapping):
            raise InputError("'frames' must map frame numbers to lists of lanes", path)
        per: dict[int, tuple[Lane, ...]] = {}
        for key, value in frames.items():
            try:
                f = int(key)
            except (TypeError, ValueError):
                raise InputError(f"frames: key {key!r} is not a frame number", path) from None
            if not isinstance(value, list):
                raise InputError(f"frames[{key}] must be a list of lanes", path)
            per[f] = tuple(_lane(r, f"frames[{key}][{i}]", path) for i, r in enumerate(value))
        return cls(base, per)


def load_lanes(path: str | PathLike[str]) -> LaneMap:
    """Read a lanes JSON file (see the module docstring). Raises InputError naming the file."""
    p = Path(path)
    try:
        record = load_json(read_input_text(p))
    except FileNotFoundError:
        raise InputError("lanes file not found", p) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON: {exc.msg}", p, exc.lineno) from None
    except RecursionError:
        raise InputError(TOO_DEEP, p) from None
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", p) from None
    except OSError as exc:  # a directory, no permission, ...
        raise InputError(f"cannot read lanes file: {exc.strerror or exc}", p) from None
    return LaneMap.from_json(record, str(p))


class Segmentation:
    """Semantic label maps, read lazily per frame (the last one is cached).

    Args:
        source: a directory of per-frame ``.npy`` / ``.png`` label maps, or one such file used
            for every frame (see the module docstring).
        labels: label id -> name; default ``<dir>/labels.json`` if present, else
            :data:`CITYSCAPES_LABELS`.
    """

    def __init__(self, source: str | PathLike[str], labels: Mapping[int, str] | None = None):
        self.source = Path(source)
        if not self.source.exists():
            raise InputError("segmentation path not found", self.source)
        if self.source.is_file() and self.source.suffix.lower() not in (".npy", ".png"):
            raise InputError("a segmentation file must be .npy or .png", self.source)
        if labels is None:
            table = (self.source if self.source.is_dir() else self.source.parent) / "labels.json"
            labels = _read_labels(table) if table.exists() else CITYSCAPES_LABELS
        self.labels: dict[int, str] = {int(k): asp_name(v) for k, v in labels.items()}
        self._cache: tuple[int, np.ndarray | None] | None = None

    def _file(self, frame: int) -> Path | None:
        if self.source.is_file():
            return self.source
        for stem in (f"{frame:06d}", str(frame)):
            for ext in (".npy", ".png"):
                p = self.source / f"{stem}{ext}"
                if p.exists():
                    return p
        return None

    def label_map(self, frame: int) -> np.ndarray | None:
        """(H, W) integer label map of ``frame``, or None when there is none for it."""
        if self._cache is not None and (self._cache[0] == frame or self.source.is_file()):
            return self._cache[1]
        path = self._file(frame)
        arr = None if path is None else _read_label_map(path)
        self._cache = (frame, arr)
        return arr

    def surface_under(
        self, frame: int, xyxy: np.ndarray, image_size: tuple[int, int] | None
    ) -> list[str | None]:
        """Label name of the ground just below each box's bottom edge (majority of three
        samples across the middle half of the edge), None where unknown or off the map.
        ``image_size`` is the size of the images the boxes are in (None: the map's size)."""
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        lm = self.label_map(frame)
        if lm is None or b.shape[0] == 0:
            return [None] * b.shape[0]
        mh, mw = lm.shape[:2]
        sx, sy = (
            (1.0, 1.0)
            if image_size is None
            else (mw / float(image_size[0]), mh / float(image_size[1]))
        )
        w = b[:, 2] - b[:, 0]
        xs = np.stack([b[:, 0] + w * f for f in (0.25, 0.5, 0.75)], axis=1) * sx
        ys = np.repeat(((b[:, 3] + 2.0) * sy)[:, None], 3, axis=1)
        ok = (xs >= 0) & (xs < mw) & (ys >= 0) & (ys < mh)
        cols = np.clip(xs.astype(np.int64), 0, mw - 1)
        rows = np.clip(ys.astype(np.int64), 0, mh - 1)
        vals = lm[rows, cols]
        out: list[str | None] = []
        for r in range(b.shape[0]):
            v = vals[r][ok[r]].tolist()
            if not v:
                out.append(None)
                continue
            best = max(set(v), key=v.count)
            out.append(self.labels.get(int(best), f"label{int(best)}"))
        return out


def _read_labels(path: Path) -> dict[int, str]:
    try:
        record = load_json(read_input_text(path))
        return {int(k): str(v) for k, v in record.items()}
    except InputError:
        raise
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", path) from None
    except OSError as exc:  # no such file, a directory, no permission ...
        raise InputError(f"cannot read labels file: {exc.strerror or exc}", path) from None
    except (json.JSONDecodeError, ValueError, AttributeError) as exc:
        raise InputError(f"labels must be a JSON object of id -> name ({exc})", path) from None
    except RecursionError:
        raise InputError(TOO_DEEP, path) from None


def _read_label_map(path: Path) -> np.ndarray:
    if path.suffix.lower() == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:  # EOFError: an empty file
            raise InputError(f"cannot read label map: {exc}", path) from None
    else:
        try:
            from PIL import Image
        except ImportError:
            raise InputError(
                "reading PNG label maps needs Pillow (pip install 'sensemaking[viz]'); "
                "or give .npy label maps",
                path,
            ) from None
        try:
            with Image.open(path) as im:
                arr = np.asarray(im)
        except (OSError, Image.DecompressionBombError) as exc:
            raise InputError(f"cannot read label map: {exc}", path) from None
    if arr.ndim == 3:
        arr = arr[..., 0]
    if arr.ndim != 2 or not np.issubdtype(arr.dtype, np.integer) or 0 in arr.shape:
        raise InputError(
            f"a label map must be a non-empty 2-D integer array, got {arr.dtype} {arr.shape}",
            path,
        )
    return arr


@dataclass(frozen=True)
class SceneContext:
    """What is known about the scene besides the tracks.

    Attributes:
        corridor: the ego corridor (:class:`Corridor`, default trapezoid).
        lanes: :class:`LaneMap` or None (then BLOCKED_LANE is skipped).
        segmentation: :class:`Segmentation` or None (then no ``surface`` facts).
    """

    corridor: Corridor = field(default_factory=Corridor)
    lanes: LaneMap | None = None
    segmentation: Segmentation | None = None

    @classmethod
    def load(
        cls,
        lanes: str | PathLike[str] | None = None,
        segmentation: str | PathLike[str] | None = None,
        labels: str | PathLike[str] | Mapping[int, str] | None = None,
        corridor: Corridor | str | Sequence[tuple[float, float]] | None = None,
    ) -> SceneContext:
        """Read the optional context files; any of them may be None. Raises InputError."""
        if isinstance(corridor, str):
            corr = Corridor.parse(corridor)
        elif corridor is None:
            corr = Corridor()
        elif isinstance(corridor, Corridor):
            corr = corridor
        else:
            corr = Corridor(tuple(corridor))
        table = _read_labels(Path(labels)) if isinstance(labels, (str, PathLike)) else labels
        return cls(
            corridor=corr,
            lanes=None if lanes is None else load_lanes(lanes),
            segmentation=None if segmentation is None else Segmentation(segmentation, table),
        )

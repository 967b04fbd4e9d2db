"""The one columnar type for boxes: detections in, tracks out.

Modelled on supervision's ``Detections``: parallel numpy arrays, validated in
the constructor, indexable with an int, slice, index array or boolean mask.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "Detections",
    "validate_detections",
    "check_frame_number",
    "MAX_FRAME",
    "check_sequence_length",
    "MAX_DETECTIONS_PER_FRAME",
    "check_frame_size",
    "MAX_LIVE_TRACKS",
    "check_live_tracks",
    "MAX_COORD",
    "IMAGE_MARGIN",
]

#: Plausibility bounds, checked on every input frame (files, the Python API through
#: :func:`validate_detections`): frame numbers lie in ``0..MAX_FRAME`` (about 3.8 days at 30 fps:
#: a larger number in a file is a typo, and would make the run loop over empty frames);
#: without an image size every coordinate is within ``±MAX_COORD`` pixels; with an image size
#: ``(W, H)`` box corners lie within ``IMAGE_MARGIN`` image sizes outside the image
#: (``-IMAGE_MARGIN * W <= x <= (1 + IMAGE_MARGIN) * W``, the same for ``y`` and ``H``); real
#: detectors reach 1.4 image sizes beyond the border (YOLOX on MOT17-05), so the bound is wide.
MAX_FRAME = 10_000_000
MAX_COORD = 1e6
IMAGE_MARGIN = 10.0
#: detections one frame may have: the tracker's per-frame work is (tracks x detections), so a
#: dense frame is refused with a clear error before any square-sized array is made (real
#: detectors give at most a few hundred: 131 on MOT17-02 with YOLOX)
MAX_DETECTIONS_PER_FRAME = 2_000
#: live tracks (confirmed, tentative, unobserved) a frame may start with: the rules end a track
#: unseen past its time limit, so live tracks <= the detections of the last
#: max(max_hidden_frames, max_missing_frames) + 1 frames -- but that is 2,000 x 31 = 62,000 at
#: the 10 fps defaults (and a user's encoding may keep tracks), so dense input could still make
#: a (tracks x detections) array of 124 M entries; past this limit the frame is refused
MAX_LIVE_TRACKS = 2_000


def _column(value: Any, n: int, dtype: type, default: float | int, name: str) -> np.ndarray:
    if value is None:
        return np.full(n, default, dtype=dtype)
    arr: np.ndarray = np.asarray(value, dtype=dtype)
    if arr.ndim == 0:
        arr = np.full(n, arr.item(), dtype=dtype)
    if arr.shape != (n,):
        raise ValueError(f"Detections.{name} must have shape ({n},), got {arr.shape}")
    return arr


@dataclass(frozen=True, eq=False, init=False)
class Detections:
    """N boxes with their attributes, all arrays of length N.

    Attributes:
        xyxy: (N, 4) float64, corners ``x1, y1, x2, y2`` in pixels (x2 > x1, y2 > y1).
        confidence: (N,) float64 detector score (any real; higher is surer). Default 1.
        class_id: (N,) int64, ids of :mod:`sensemaking.classes`. Default 0 (unknown).
        tracker_id: (N,) int64 track id, -1 where no track is assigned.
        frame: (N,) int64 frame number as in the source (MOT 1-based, KITTI 0-based).
        source_row: (N,) int64, 1-based line in the input file the box came from, -1 if none.
        data: extra per-box columns, each an array whose first axis has length N
            (e.g. ``"location"`` (N, 3) of a 3D detector, read by :attr:`depth`).

    The constructor takes each (N,) column as an array, a scalar (repeated N times) or None
    (the default above); the attributes are always arrays.
    """

    xyxy: np.ndarray
    confidence: np.ndarray
    class_id: np.ndarray
    tracker_id: np.ndarray
    frame: np.ndarray
    source_row: np.ndarray
    data: Mapping[str, np.ndarray]

    def __init__(
        self,
        xyxy: ArrayLike,
        confidence: ArrayLike | None = None,
        class_id: ArrayLike | None = None,
        tracker_id: ArrayLike | None = None,
        frame: ArrayLike | None = None,
        source_row: ArrayLike | None = None,
        data: Mapping[str, ArrayLike] | None = None,
    ) -> None:
        boxes = np.asarray(xyxy, dtype=np.float64)
        if boxes.size == 0:
            boxes = boxes.reshape(0, 4)
        if boxes.ndim != 2 or boxes.shape[1] != 4:
            raise ValueError(f"Detections.xyxy must have shape (N, 4), got {boxes.shape}")
        n = boxes.shape[0]
        set_ = object.__setattr__
        set_(self, "xyxy", boxes)
        set_(self, "confidence", _column(confidence, n, np.float64, 1.0, "confidence"))
        set_(self, "class_id", _column(class_id, n, np.int64, 0, "class_id"))
        set_(self, "tracker_id", _column(tracker_id, n, np.int64, -1, "tracker_id"))
        set_(self, "frame", _column(frame, n, np.int64, 0, "frame"))
        set_(self, "source_row", _column(source_row, n, np.int64, -1, "source_row"))
        columns = {}
        for key, value in dict(data or {}).items():
            arr = np.asarray(value)
            if arr.ndim == 0 or arr.shape[0] != n:
                raise ValueError(
                    f"Detections.data[{key!r}] must have length {n}, got shape {arr.shape}"
                )
            columns[key] = arr
        set_(self, "data", columns)

    # construction -------------------------------------------------------------------------
    @classmethod
    def empty(cls) -> Detections:
        """No boxes."""
        return cls(xyxy=np.zeros((0, 4)))

    @classmethod
    def trusted(
        cls,
        xyxy: np.ndarray,
        confidence: np.ndarray,
        class_id: np.ndarray,
        tracker_id: np.ndarray,
        frame: np.ndarray,
        source_row: np.ndarray,
        data: dict[str, np.ndarray],
    ) -> Detections:
        """Without validation, for callers whose columns are valid already: ``xyxy`` (N, 4)
        float64, the others (N,) of the dtypes above, ``data`` arrays of length N (the tracker's
        output, built every frame). Equal to ``Detections(...)`` on such input."""
        obj = object.__new__(cls)
        for name, value in (
            ("xyxy", xyxy),
            ("confidence", confidence),
            ("class_id", class_id),
            ("tracker_id", tracker_id),
            ("frame", frame),
            ("source_row", source_row),
            ("data", data),
        ):
            object.__setattr__(obj, name, value)
        return obj

    @classmethod
    def from_xywh(cls, xywh: np.ndarray, **kwargs: Any) -> Detections:
        """From (N, 4) ``x, y, w, h`` (top-left corner plus size, pixels)."""
        xywh = np.asarray(xywh, dtype=np.float64).reshape(-1, 4)
        xyxy = xywh.copy()
        xyxy[:, 2:] += xyxy[:, :2]
        return cls(xyxy=xyxy, **kwargs)

    @classmethod
    def concatenate(cls, parts: list[Detections]) -> Detections:
        """Stack several Detections; ``data`` keys must agree."""
        parts = [p for p in parts if len(p)] or parts[:1]
        if not parts:
            return cls.empty()
        keys = set(parts[0].data)
        for p in parts[1:]:
            if set(p.data) != keys:
                raise ValueError("cannot concatenate Detections whose data keys differ")
        return cls(
            xyxy=np.concatenate([p.xyxy for p in parts]),
            confidence=np.concatenate([p.confidence for p in parts]),
            class_id=np.concatenate([p.class_id for p in parts]),
            tracker_id=np.concatenate([p.tracker_id for p in parts]),
            frame=np.concatenate([p.frame for p in parts]),
            source_row=np.concatenate([p.source_row for p in parts]),
            data={k: np.concatenate([p.data[k] for p in parts]) for k in keys},
        )

    # access -------------------------------------------------------------------------------
    def __len__(self) -> int:
        return int(self.xyxy.shape[0])

    def __getitem__(self, index: int | slice | np.ndarray | list[int]) -> Detections:
        if isinstance(index, (int, np.integer)):
            index = [int(index)]
        return Detections(
            xyxy=self.xyxy[index],
            confidence=self.confidence[index],
            class_id=self.class_id[index],
            tracker_id=self.tracker_id[index],
            frame=self.frame[index],
            source_row=self.source_row[index],
            data={k: v[index] for k, v in self.data.items()},
        )

    def with_(self, **changes: Any) -> Detections:
        """A copy with some fields replaced (validated again)."""
        return replace(self, **changes)

    @property
    def xywh(self) -> np.ndarray:
        """(N, 4) ``x, y, w, h``: top-left corner and size in pixels."""
        out = self.xyxy.copy()
        out[:, 2:] -= out[:, :2]
        return out

    @property
    def depth(self) -> np.ndarray:
        """(N,) distance in metres along the camera's optical axis, NaN where unknown: the
        ``"depth"`` data column if there is one, else the ``z`` of a 3D detector's
        ``"location"`` column (KITTI camera coordinates, as PointRCNN gives them). Depths that
        are not finite or not positive (placeholders such as KITTI's -1000) are unknown."""
        z = self.data.get("depth")
        if z is None:
            loc = self.data.get("location")
            if loc is None or loc.ndim != 2 or loc.shape[1] != 3:
                return np.full(len(self), np.nan)
            z = loc[:, 2]
        z = np.asarray(z, dtype=np.float64).reshape(len(self))
        with np.errstate(invalid="ignore"):
            return np.where(np.isfinite(z) & (z > 0), z, np.nan)

    @property
    def area(self) -> np.ndarray:
        """(N,) box areas in square pixels."""
        return (self.xyxy[:, 2] - self.xyxy[:, 0]) * (self.xyxy[:, 3] - self.xyxy[:, 1])

    def frames(self) -> Iterator[tuple[int, Detections]]:
        """Yield ``(frame, detections of that frame)`` in increasing frame order."""
        if len(self) == 0:
            return
        order = np.argsort(self.frame, kind="stable")
        frames = self.frame[order]
        cuts = np.flatnonzero(np.diff(frames)) + 1
        for chunk in np.split(order, cuts):
            yield int(self.frame[chunk[0]]), self[chunk]

    def __repr__(self) -> str:
        return f"Detections(n={len(self)}, data={sorted(self.data)})"


def check_frame_number(frame: Any, what: str = "frame") -> int:
    """``frame`` as an int in ``0..MAX_FRAME``; InputError (a ValueError) otherwise."""
    from sensemaking.errors import InputError

    if isinstance(frame, bool) or not isinstance(frame, (int, np.integer)):
        raise InputError(f"{what} must be an integer, got {frame!r}")
    if not 0 <= int(frame) <= MAX_FRAME:
        raise InputError(
            f"{what} {int(frame)} is outside 0..{MAX_FRAME} (the plausibility bound "
            "sensemaking.detections.MAX_FRAME)"
        )
    return int(frame)


def check_sequence_length(
    value: float, what: str, path: str | os.PathLike[str], line: int | None = None
) -> None:
    """InputError naming ``path`` (and ``line``) when a sequence's stated length ``value``
    (frames; a seqinfo's ``what`` field) is past :data:`MAX_FRAME`."""
    from sensemaking.errors import InputError

    if value > MAX_FRAME:
        raise InputError(
            f"{what} {value} is beyond the plausibility bound {MAX_FRAME} "
            "(sensemaking.detections.MAX_FRAME)",
            path,
            line,
        )


def check_frame_size(
    n: int, frame: int | None = None, path: str | None = None, line: int | None = None
) -> None:
    """Refuse a frame with more than :data:`MAX_DETECTIONS_PER_FRAME` detections
    (:class:`~sensemaking.errors.FrameLimitError` naming the file line when known)."""
    from sensemaking.errors import FrameLimitError

    if n > MAX_DETECTIONS_PER_FRAME:
        which = "a frame" if frame is None else f"frame {frame}"
        raise FrameLimitError(
            f"{which} has {n} detections or more, more than the per-frame limit of "
            f"{MAX_DETECTIONS_PER_FRAME} (sensemaking.detections.MAX_DETECTIONS_PER_FRAME; "
            "raise the detector's confidence threshold)",
            path,
            line,
        )


def check_live_tracks(n: int, frame: int | None = None) -> None:
    """Refuse to track a frame when more than :data:`MAX_LIVE_TRACKS` tracks are live before
    it (:class:`~sensemaking.errors.FrameLimitError`): bounds the frame's (tracks x detections)
    work."""
    from sensemaking.errors import FrameLimitError

    if n > MAX_LIVE_TRACKS:
        which = "a frame" if frame is None else f"frame {frame}"
        raise FrameLimitError(
            f"{which}: {n} live tracks, more than the limit of {MAX_LIVE_TRACKS} "
            "(sensemaking.detections.MAX_LIVE_TRACKS); the detections are too dense to track: "
            "raise the detector's confidence threshold, start_confidence or min_hits"
        )


def validate_detections(
    dets: Detections, image_size: tuple[int, int] | None = None, path: str | None = None
) -> Detections:
    """Check one frame's detections before they reach a tracker; return them unchanged.

    Refused (:class:`~sensemaking.errors.InputError`, a ValueError): a non-finite box or
    confidence, x2 <= x1 or y2 <= y1, a coordinate outside the plausibility bounds
    (:data:`MAX_COORD`, :data:`IMAGE_MARGIN`), a negative class id, a frame outside
    ``0..MAX_FRAME``. The error names the box's file line (``source_row``, with ``path``) when it
    has one, else its index. Checking before the update leaves a tracker as it was on refusal.
    """
    from sensemaking.errors import InputError

    n = len(dets)
    if n == 0:
        return dets
    xyxy, conf = dets.xyxy, dets.confidence
    finite_box = np.isfinite(xyxy).all(axis=1)
    with np.errstate(invalid="ignore"):
        if image_size is None:
            inside = (np.abs(xyxy) <= MAX_COORD).all(axis=1)
            bound = f"within +-{MAX_COORD:g} px"
        else:
            w, h = float(image_size[0]), float(image_size[1])
            lo = np.array([-IMAGE_MARGIN * w, -IMAGE_MARGIN * h] * 2)
            hi = np.array([(1 + IMAGE_MARGIN) * w, (1 + IMAGE_MARGIN) * h] * 2)
            inside = ((xyxy >= lo) & (xyxy <= hi)).all(axis=1)
            bound = (
                f"within {IMAGE_MARGIN:g} image size of the {int(w)}x{int(h)} image "
                f"(x in {lo[0]:g}..{hi[0]:g}, y in {lo[1]:g}..{hi[1]:g})"
            )
        ordered = (xyxy[:, 2] > xyxy[:, 0]) & (xyxy[:, 3] > xyxy[:, 1])
    checks = (
        (~finite_box, lambda i: f"box {_fmt_box(xyxy[i])} is not finite"),
        (
            ~np.isfinite(conf),
            lambda i: f"confidence must be a finite number, got {float(conf[i])!r}",
        ),
        (~ordered, lambda i: f"box {_fmt_box(xyxy[i])} must have x2 > x1 and y2 > y1"),
        (~inside, lambda i: f"box {_fmt_box(xyxy[i])} is implausible: corners must lie {bound}"),
        (dets.class_id < 0, lambda i: f"class id must be >= 0, got {int(dets.class_id[i])}"),
        (
            (dets.frame < 0) | (dets.frame > MAX_FRAME),
            lambda i: f"frame {int(dets.frame[i])} is outside 0..{MAX_FRAME}",
        ),
    )
    for bad, problem in checks:
        if bad.any():
            i = int(np.argmax(bad))
            row = int(dets.source_row[i])
            if row > 0 and path is not None:
                raise InputError(problem(i), path, row)
            where = f"detection {i}" + (f" (line {row})" if row > 0 else "")
            raise InputError(f"{where}: {problem(i)}", path)
    return dets


def _fmt_box(box: np.ndarray) -> str:
    return "[" + ", ".join(f"{float(v):g}" for v in box) + "]"

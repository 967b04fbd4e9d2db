"""MOTChallenge text files: ``seqinfo.ini``, detections, ground truth and tracker results.

Rows are ``frame,id,x,y,w,h,...`` with 1-based frames and the box's top-left corner ``x, y``
plus its size ``w, h`` in pixels. Numbers are kept as they are (no shift of the 1-based pixel
origin); boxes become :class:`~sensemaking.detections.Detections` corners ``x, y, x + w, y + h``.
"""

from __future__ import annotations

import configparser
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from sensemaking.detections import MAX_FRAME, Detections, check_sequence_length
from sensemaking.errors import InputError
from sensemaking.io.atomic import atomic_write
from sensemaking.io.tables import PathLike, Table, frame_order, ints, nums, parse_table, read_text

__all__ = ["SequenceInfo", "read_seqinfo", "read_mot", "write_mot", "format_mot", "mot_from_table"]

log = logging.getLogger(__name__)

MotKind = Literal["det", "gt", "results"]

_DET_NAMES = (
    "frame",
    "id",
    "x",
    "y",
    "width",
    "height",
    "confidence",
    "world x",
    "world y",
    "world z",
)
_GT17_NAMES = ("frame", "id", "x", "y", "width", "height", "consider flag", "class", "visibility")
_GT15_NAMES = (
    "frame",
    "id",
    "x",
    "y",
    "width",
    "height",
    "consider flag",
    "world x",
    "world y",
    "world z",
)
#: per kind: allowed number of comma-separated fields -> column names
MOT_LAYOUTS: dict[str, dict[int, tuple[str, ...]]] = {
    "det": {n: _DET_NAMES for n in range(7, 11)},
    "gt": {9: _GT17_NAMES, 10: _GT15_NAMES},
    "results": {n: _DET_NAMES for n in range(7, 11)},
}


@dataclass(frozen=True)
class SequenceInfo:
    """A sequence's name, length in frames, image size in pixels and frame rate in frames/s."""

    name: str
    length: int
    width: int
    height: int
    fps: float


def read_seqinfo(path: PathLike) -> SequenceInfo:
    """Read a MOTChallenge ``seqinfo.ini`` (``path`` is the file or the sequence folder holding
    it).

    Needs ``seqLength``, ``imWidth``, ``imHeight`` and ``frameRate`` in section ``[Sequence]``;
    ``name`` defaults to the folder name.
    """
    p = Path(path)
    if p.is_dir():
        p = p / "seqinfo.ini"
    text = read_text(p)
    parser = configparser.ConfigParser(interpolation=None)
    try:
        parser.read_string(text, source=str(p))
    except configparser.MissingSectionHeaderError as exc:
        raise InputError("expected a section header such as [Sequence]", p, exc.lineno) from None
    except configparser.ParsingError as exc:
        lineno = exc.errors[0][0] if exc.errors else None
        raise InputError("not an ini file line (expected key=value)", p, lineno) from None
    except configparser.Error as exc:
        raise InputError(f"bad ini file: {exc.message}", p) from None
    if not parser.has_section("Sequence"):
        raise InputError("no [Sequence] section", p)
    section = parser["Sequence"]

    def number(key: str, kind: type) -> float:
        if key not in section:
            raise InputError(f"missing key {key!r} in [Sequence]", p)
        raw = section[key].strip()
        try:
            value = kind(raw)
        except ValueError:
            raise InputError(
                f"{key} must be {'an integer' if kind is int else 'a number'}, got {raw!r}", p
            ) from None
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{key} must be positive, got {raw!r}", p)
        if key == "seqLength":
            check_sequence_length(value, key, p)
        return value

    return SequenceInfo(
        name=section.get("name", "").strip() or p.resolve().parent.name,
        length=int(number("seqLength", int)),
        width=int(number("imWidth", int)),
        height=int(number("imHeight", int)),
        fps=float(number("frameRate", float)),
    )


def read_mot(path: PathLike, kind: MotKind = "det", default_class: int = 1) -> Detections:
    """Read a MOTChallenge file into Detections (frames 1-based, ``source_row`` = file line).

    ``kind="det"``: ``frame,-1,x,y,w,h,score[,...]`` (7 to 10 fields); class ``default_class``,
    no track ids. Lines must be sorted by frame; an empty file is an error. Boxes of zero width or
    height (detector artefacts) are dropped with a warning.

    ``kind="gt"``: MOT16/17/20 ``frame,id,x,y,w,h,consider,class,visibility`` gives ``data``
    ``"consider"`` (N,) int and ``"visibility"`` (N,) float, class from the file (-1 ->
    ``default_class``). MOT15 ``frame,id,x,y,w,h,consider,wx,wy,wz`` (10 fields) has no class:
    ``default_class``, visibility -1 (unknown). Any line order; returned sorted by (frame, id).

    ``kind="results"``: ``frame,id,x,y,w,h,score[,...]``; id -> ``tracker_id``, class
    ``default_class``. Any line order (trackers write by frame or by id), kept as in the file;
    an empty file gives empty Detections.
    """
    if kind not in MOT_LAYOUTS:
        raise ValueError(f"unknown MOT file kind {kind!r}; expected 'det', 'gt' or 'results'")
    table = parse_table(path, sep=",", names=MOT_LAYOUTS[kind])
    return mot_from_table(table, kind, default_class)


def mot_from_table(
    table: Table,
    kind: MotKind = "det",
    default_class: int = 1,
    logger: logging.Logger | None = log,
) -> Detections:
    """:func:`read_mot` of an already parsed table (a whole file, or one chunk of it)."""
    path = table.path
    n = len(table)
    if n == 0:
        if kind == "det":
            raise InputError("no detections in file", path)
        no_data = (
            {"consider": np.zeros(0, np.int64), "visibility": np.zeros(0)} if kind == "gt" else {}
        )
        return Detections(xyxy=np.zeros((0, 4)), data=no_data)

    frames = table.integers(
        0,
        minimum=1,
        what=" (MOTChallenge frames are 1-based)",
        maximum=MAX_FRAME,
        maximum_why=" (sensemaking.detections.MAX_FRAME)",
    )
    ids = table.integers(1) if kind != "det" else np.full(n, -1, dtype=np.int64)
    v = table.values
    table.finite([2, 3, 4, 5] if kind == "gt" else [2, 3, 4, 5, 6])
    keep = table.positive_size(v[:, 4], v[:, 5], drop_zero=kind == "det", logger=logger)
    if kind == "det":
        table.sorted_frames(frames)  # the online tracker consumes detections in order

    classes = np.full(n, default_class, dtype=np.int64)
    confidence = np.ones(n) if kind == "gt" else v[:, 6]
    data: dict[str, np.ndarray] = {}
    if kind == "gt":
        data["consider"] = table.integers(6)
        if table.ncols == 9:
            cls = table.integers(7)
            classes = np.where(cls == -1, default_class, cls)
            table.finite([8])
            data["visibility"] = v[:, 8].copy()
        else:
            data["visibility"] = np.full(n, -1.0)
    with np.errstate(over="ignore"):  # x + w overflowing is reported below
        dets = Detections.from_xywh(
            v[:, 2:6],
            confidence=confidence,
            class_id=classes,
            tracker_id=ids if kind != "det" else None,
            frame=frames,
            source_row=table.rows,
            data=data,
        )
    box = dets.xyxy
    bad = keep & ~(
        np.isfinite(box).all(axis=1) & (box[:, 2] > box[:, 0]) & (box[:, 3] > box[:, 1])
    )
    if bad.any():
        table.fail(
            int(np.argmax(bad)),
            "box corner x + width or y + height is not representable in float64",
        )
    if not keep.all():
        dets = dets[keep]
    if kind == "gt":
        assert dets.tracker_id is not None and dets.frame is not None  # set by __post_init__
        dets = dets[np.lexsort((dets.tracker_id, dets.frame))]
    return dets


def write_mot(path: PathLike, tracks: Detections) -> None:
    """Write MOTChallenge results ``frame,id,x,y,w,h,conf,-1,-1,-1`` atomically, sorted by frame.

    Numbers are written losslessly: reading the file back with :func:`read_mot`
    (``kind="results"``) gives the same boxes, scores, frames and ids bit for bit.
    """
    text = format_mot(tracks)
    with atomic_write(path) as handle:
        handle.write(text)


def format_mot(tracks: Detections) -> str:
    """The lines :func:`write_mot` writes (sorted by frame, stable): written frame by frame, the
    pieces of a frame-ordered run join to the same text as the whole."""
    xyxy = tracks.xyxy
    if len(tracks) and not np.isfinite(xyxy).all():
        raise ValueError("cannot write boxes with non-finite coordinates")
    if len(tracks) and not ((xyxy[:, 2] > xyxy[:, 0]) & (xyxy[:, 3] > xyxy[:, 1])).all():
        raise ValueError("cannot write boxes of non-positive width or height")
    assert tracks.frame is not None and tracks.tracker_id is not None  # set by __post_init__
    assert tracks.confidence is not None
    order = frame_order(tracks.frame)
    xyxy = xyxy[order]
    x1, y1 = xyxy[:, 0], xyxy[:, 1]
    cols = zip(
        ints(tracks.frame[order]),
        ints(tracks.tracker_id[order]),
        nums(x1),
        nums(y1),
        nums(_span(x1, xyxy[:, 2])),
        nums(_span(y1, xyxy[:, 3])),
        nums(tracks.confidence[order]),
        strict=True,
    )
    return "".join(f"{f},{i},{x},{y},{w},{h},{c},-1,-1,-1\n" for f, i, x, y, w, h, c in cols)


def _span(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(N,) sizes ``s`` with ``lo + s == hi`` exactly in float64, so ``x + w`` recovers ``x2``.

    ``hi - lo`` rounds, and adding it back to ``lo`` may miss ``hi`` by an ulp. Prefer the size
    with the fewest decimals that hits (so ``0.1 + 0.2`` is written back as width ``0.2``), else
    step to the neighbouring float until the sum hits. A hit always exists for boxes that were
    read as ``x, w``; for other boxes (rare rounding ties) the nearest size is kept, 1 ulp off.
    """
    diff = hi - lo
    size = diff.copy()
    for _ in range(8):
        total = lo + size
        low, high = total < hi, total > hi
        if not (low.any() or high.any()):
            break
        size = np.where(
            low, np.nextafter(size, np.inf), np.where(high, np.nextafter(size, -np.inf), size)
        )
    todo = np.ones(len(size), dtype=bool)
    with np.errstate(over="ignore", invalid="ignore"):
        for decimals in range(13):
            short = np.round(diff[todo], decimals)
            hit = lo[todo] + short == hi[todo]
            idx = np.flatnonzero(todo)[hit]
            size[idx] = short[hit]
            todo[idx] = False
            if not todo.any():
                break
    return size

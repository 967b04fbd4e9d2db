"""Detections read frame by frame: memory bounded by a chunk of lines, not by the file.

:func:`iter_detection_frames` parses a MOTChallenge or KITTI detection file in chunks of lines
with the same checks and messages (``file:line: problem``) as the whole-file readers of
:mod:`sensemaking.io.formats`, and yields ``(frame, Detections)`` in increasing frame order.
:func:`scan_detections` runs it once without keeping anything, so that a run can refuse a bad
file before it does any work and know its frame range.
"""

from __future__ import annotations

import heapq
import logging
from collections.abc import Collection, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensemaking.detections import (
    MAX_DETECTIONS_PER_FRAME,
    MAX_FRAME,
    Detections,
    check_frame_size,
    validate_detections,
)
from sensemaking.errors import InputError
from sensemaking.io.formats import Format
from sensemaking.io.kitti import (
    KITTI_DETECTION_LAYOUTS,
    KITTI_LABEL_LAYOUTS,
    kitti_detections_from_table,
    kitti_labels_from_table,
)
from sensemaking.io.mot import MOT_LAYOUTS, mot_from_table
from sensemaking.io.tables import PathLike, class_id_of, parse_lines, reading
from sensemaking.io.text import refuse_stream

__all__ = [
    "iter_detection_frames",
    "scan_detections",
    "merge_frames",
    "sequence_name",
    "DetectionsSummary",
    "CHUNK_LINES",
]

log = logging.getLogger(__name__)

#: lines parsed at a time (about 1.3 MB of float64 for MOT's 10 columns; a chunk's lines, table
#: and frames are held at once: ~15 MB at 65,536 lines, which was a tenth of a run's peak)
CHUNK_LINES = 16384


@dataclass(frozen=True)
class DetectionsSummary:
    """What a pass over a detection file found: ``first``/``last`` frame with detections,
    ``frames`` (number of frames with detections), ``detections`` (boxes kept), ``dropped``
    (boxes of zero width or height dropped), ``classes`` (the class ids of the boxes kept,
    sorted), ``data_keys`` (the ``Detections.data`` columns of the file's kind, sorted)."""

    first: int | None
    last: int | None
    frames: int
    detections: int
    dropped: int
    classes: tuple[int, ...] = ()
    data_keys: tuple[str, ...] = ()


def _layout(path: PathLike, fmt: Format) -> tuple[str, dict, tuple[int, ...]]:
    """(kind, allowed field counts -> names, text columns) of the file, from its first line."""
    if fmt == "mot":
        return "mot", MOT_LAYOUTS["det"], ()
    if fmt != "kitti":
        raise ValueError(f"unknown format {fmt!r}; expected 'mot' or 'kitti'")
    with reading(path) as p, p.open(encoding="utf-8-sig") as handle:
        first = next(((i, s) for i, s in enumerate(handle, start=1) if s.strip()), None)
    if first is None:
        return "kitti-det", KITTI_DETECTION_LAYOUTS, ()
    number, line = first
    line = line.strip()
    if "," in line:
        n = line.count(",") + 1
        if n in KITTI_DETECTION_LAYOUTS:
            return "kitti-det", KITTI_DETECTION_LAYOUTS, ()
        got = f"{n} comma-separated"
    else:
        n = len(line.split())
        if n in KITTI_LABEL_LAYOUTS:
            return "kitti-labels", KITTI_LABEL_LAYOUTS, (2,)
        got = f"{n} space-separated"
    raise InputError(
        "cannot tell the KITTI file kind: expected 17 or 18 space-separated fields (labels or "
        "tracking results), 6 comma-separated (RRC detections) or 15 comma-separated "
        f"(PointRCNN detections), got {got}",
        path,
        number,
    )


def _chunks(path: PathLike, size: int) -> Iterator[tuple[list[str], np.ndarray]]:
    """Non-blank lines in chunks of ``size``, with their 1-based line numbers."""
    with reading(path) as p, p.open(encoding="utf-8-sig", newline=None) as handle:
        body: list[str] = []
        rows: list[int] = []
        for number, line in enumerate(handle, start=1):
            if not line.strip():
                continue
            body.append(line.rstrip("\n"))
            rows.append(number)
            if len(body) >= size:
                yield body, np.asarray(rows, dtype=np.int64)
                body, rows = [], []
        if body:
            yield body, np.asarray(rows, dtype=np.int64)


def iter_detection_frames(
    path: PathLike,
    fmt: Format,
    class_name: str | None = None,
    *,
    image_size: tuple[int, int] | None = None,
    last_frame: int | None = None,
    chunk_lines: int = CHUNK_LINES,
    summary: list[DetectionsSummary] | None = None,
) -> Iterator[tuple[int, Detections]]:
    """``(frame, Detections of that frame)`` for every frame with detections, in order.

    The file must be sorted by frame (the online tracker consumes it in order); kinds and
    checks as :func:`~sensemaking.io.formats.read_detections`, plus the plausibility bounds of
    :func:`~sensemaking.detections.validate_detections` (with ``image_size``) and frame numbers
    at most ``last_frame`` (the sequence's last, from its seqinfo) or
    :data:`~sensemaking.detections.MAX_FRAME`. An empty file (MOT or KITTI: a sequence where the
    detector found nothing) yields nothing, with a warning.
    Boxes of zero width or height are dropped with one warning for the file. When done, a
    :class:`DetectionsSummary` is appended to ``summary`` (if given). A regular file only
    (``track`` reads a pipe into one first).
    """
    refuse_stream(path)
    kind, names, text_cols = _layout(path, fmt)
    sep = None if kind == "kitti-labels" else ","
    default_class = 1 if class_name is None or fmt != "mot" else class_id_of(class_name, path)
    limit = MAX_FRAME if last_frame is None else min(int(last_frame), MAX_FRAME)
    first: int | None = None
    previous: int | None = None  # last frame of the previous chunk
    pending: Detections | None = None  # the last frame of a chunk, perhaps continued in the next
    n_frames = n_dets = dropped = 0
    last: int | None = None
    first_drop: int | None = None
    classes: set[int] = set()
    data_keys: tuple[str, ...] = ()
    for body, rows in _chunks(path, chunk_lines):
        table = parse_lines(path, body, rows, sep=sep, names=names, text_cols=text_cols)
        names = {table.ncols: names[table.ncols]}  # every chunk has the first line's layout
        frames_col = table.integers(
            0,
            minimum=1 if fmt == "mot" else 0,
            what=" (MOTChallenge frames are 1-based)" if fmt == "mot" else "",
        )
        table.sorted_frames(frames_col)
        if previous is not None and frames_col[0] < previous:
            table.fail(
                0,
                f"frame {frames_col[0]} comes after frame {previous}: "
                "lines must be sorted by frame",
            )
        over = frames_col > limit
        if over.any():
            i = int(np.argmax(over))
            why = (
                f"the sequence has frames up to {last_frame} (seqinfo)"
                if last_frame is not None and limit == last_frame
                else f"the plausibility bound is {MAX_FRAME} (sensemaking.detections.MAX_FRAME)"
            )
            table.fail(i, f"frame {frames_col[i]} is beyond the sequence: {why}")
        previous = int(frames_col[-1])
        if kind == "mot":
            dets = mot_from_table(table, "det", default_class, logger=None)
        elif kind == "kitti-det":
            dets = kitti_detections_from_table(table, class_name, logger=None)
        else:
            dets = kitti_labels_from_table(table)
        assert dets.frame is not None and dets.source_row is not None  # set by __post_init__
        if len(dets) < len(table):
            kept = np.isin(table.rows, dets.source_row)
            dropped += int((~kept).sum())
            if first_drop is None:
                first_drop = int(table.rows[int(np.argmax(~kept))])
        validate_detections(dets, image_size, str(path))
        if first is None and len(dets):
            first = int(dets.frame[0])
        if len(dets):
            assert dets.class_id is not None  # set by __post_init__
            classes.update(np.unique(dets.class_id).tolist())
            data_keys = tuple(sorted(dets.data))
        parts = _split_frames(dets)
        if not parts:
            continue  # every box of the chunk dropped: a pending frame may still go on
        if pending is not None:
            assert pending.frame is not None  # set by __post_init__
            if parts[0][0] == int(pending.frame[0]):
                parts[0] = (parts[0][0], Detections.concatenate([pending, parts[0][1]]))
            else:
                parts.insert(0, (int(pending.frame[0]), pending))
        for f, d in parts:  # a frame grows over chunks: bounded as it grows
            if len(d) > MAX_DETECTIONS_PER_FRAME:
                assert d.source_row is not None  # set by __post_init__
                check_frame_size(len(d), f, str(path), int(d.source_row[MAX_DETECTIONS_PER_FRAME]))
        *complete, (_, pending) = parts
        for f, d in complete:
            n_frames += 1
            n_dets += len(d)
            last = f
            yield f, _ordered(d, kind)
    if previous is None:  # a sequence where the detector found nothing: nothing to track
        log.warning("%s: no detections in file", path)
    if pending is not None:
        n_frames += 1
        n_dets += len(pending)
        assert pending.frame is not None  # set by __post_init__
        last = int(pending.frame[0])
        yield last, _ordered(pending, kind)
    if dropped:
        log.warning(
            "%s: dropped %d detection(s) of zero width or height (first on line %d)",
            path,
            dropped,
            first_drop,
        )
    if summary is not None:
        summary.append(
            DetectionsSummary(
                first, last, n_frames, n_dets, dropped, tuple(sorted(classes)), data_keys
            )
        )


def _split_frames(dets: Detections) -> list[tuple[int, Detections]]:
    """``(frame, rows of that frame)`` of frame-sorted, validated Detections (slices, not
    copies)."""
    if len(dets) == 0:
        return []
    assert dets.frame is not None  # set by __post_init__
    cuts = np.flatnonzero(np.diff(dets.frame)) + 1
    starts = [0, *cuts.tolist()]
    ends = [*cuts.tolist(), len(dets)]
    cols = ("xyxy", "confidence", "class_id", "tracker_id", "frame", "source_row")
    return [
        (
            int(dets.frame[a]),
            Detections.trusted(
                **{c: getattr(dets, c)[a:b] for c in cols},
                data={k: v[a:b] for k, v in dets.data.items()},
            ),
        )
        for a, b in zip(starts, ends, strict=True)
    ]


def _ordered(dets: Detections, kind: str) -> Detections:
    """A frame of a label file in (frame, id) order, as :func:`read_kitti_labels` gives it."""
    if kind != "kitti-labels" or len(dets) < 2:
        return dets
    assert dets.tracker_id is not None  # set by __post_init__
    return dets[np.argsort(dets.tracker_id, kind="stable")]


def scan_detections(
    path: PathLike,
    fmt: Format,
    class_name: str | None = None,
    *,
    image_size: tuple[int, int] | None = None,
    last_frame: int | None = None,
    chunk_lines: int = CHUNK_LINES,
) -> DetectionsSummary:
    """Check a whole detection file as :func:`iter_detection_frames` does, keeping nothing."""
    out: list[DetectionsSummary] = []
    for _ in iter_detection_frames(
        path,
        fmt,
        class_name,
        image_size=image_size,
        last_frame=last_frame,
        chunk_lines=chunk_lines,
        summary=out,
    ):
        pass
    return out[0]


def merge_frames(
    streams: Sequence[Iterable[tuple[int, Detections]]],
    keep_data: Collection[str] | None = None,
) -> Iterator[tuple[int, Detections]]:
    """Several ``(frame, Detections)`` streams of one sequence (each in increasing frame order,
    e.g. one :func:`iter_detection_frames` per class file) as one: a frame's rows are those of
    every stream with that frame, in stream order. ``keep_data``: the ``data`` columns kept
    (the others dropped, so that detectors with different columns can be mixed); None keeps
    them all (they must then agree). Memory: one frame per stream."""
    tagged = (((f, k, d) for f, d in stream) for k, stream in enumerate(streams))
    # heapq.merge is stable: equal frames come in stream order
    merged = heapq.merge(*tagged, key=lambda item: item[0])
    keep = None if keep_data is None else set(keep_data)
    frame: int | None = None
    parts: list[Detections] = []
    for f, _, dets in merged:
        if keep is not None and set(dets.data) != keep:
            dets = dets.with_(data={k: v for k, v in dets.data.items() if k in keep})
        if f != frame and parts:
            assert frame is not None
            yield frame, parts[0] if len(parts) == 1 else Detections.concatenate(parts)
            parts = []
        frame = f
        parts.append(dets)
    if parts:
        assert frame is not None
        yield frame, parts[0] if len(parts) == 1 else Detections.concatenate(parts)


def sequence_name(path: PathLike, fmt: Format) -> str:
    """The sequence a detection file belongs to, by the benchmark's layout: KITTI
    ``<class>/<seq>.txt`` -> ``<seq>``; MOTChallenge ``<seq>/det/det.txt`` -> ``<seq>``, any
    other MOT file its name without extension."""
    p = Path(path)
    if fmt == "mot" and p.name == "det.txt" and p.parent.name == "det":
        return p.parent.parent.name
    return p.stem

"""KITTI tracking text files: ``seqinfo.csv``, labels / tracking results, RRC and PointRCNN
detections.

Frames are 0-based; boxes are corners ``x1 y1 x2 y2`` in pixels, kept as they are.
"""

from __future__ import annotations

import csv
import io
import logging
import math
from pathlib import Path

import numpy as np
from scipy.special import expit

from sensemaking.classes import CLASS_IDS, KITTI_NAMES, class_id
from sensemaking.classes import class_name as _class_name
from sensemaking.detections import MAX_FRAME, Detections, check_sequence_length
from sensemaking.errors import InputError
from sensemaking.io.atomic import atomic_write
from sensemaking.io.mot import SequenceInfo
from sensemaking.io.tables import (
    PathLike,
    Table,
    class_id_of,
    frame_order,
    ints,
    num,
    nums,
    parse_table,
    read_text,
)

__all__ = [
    "read_kitti_seqinfo",
    "read_kitti_labels",
    "write_kitti",
    "read_kitti_detections",
    "format_kitti",
    "kitti_detections_from_table",
    "kitti_labels_from_table",
]

log = logging.getLogger(__name__)

_LABEL_NAMES = (
    "frame",
    "id",
    "type",
    "truncated",
    "occluded",
    "alpha",
    "x1",
    "y1",
    "x2",
    "y2",
    "height",
    "width",
    "length",
    "X",
    "Y",
    "Z",
    "rotation_y",
    "score",
)
_RRC_NAMES = ("frame", "x1", "y1", "x2", "y2", "score")
_POINTRCNN_NAMES = (
    "frame",
    "type",
    "x1",
    "y1",
    "x2",
    "y2",
    "score",
    "height",
    "width",
    "length",
    "X",
    "Y",
    "Z",
    "rotation_y",
    "alpha",
)
#: PointRCNN type code -> class id
_POINTRCNN_CLASSES = {1: CLASS_IDS["pedestrian"], 2: CLASS_IDS["car"], 3: CLASS_IDS["cyclist"]}
_SEQINFO_COLUMNS = ("seq", "num_frames", "im_width", "im_height", "frame_rate")


def read_kitti_seqinfo(csv_path: PathLike) -> dict[str, SequenceInfo]:
    """Sequence name (as written, e.g. ``"0000"``) -> info, from ``training/seqinfo.csv``.

    Columns ``seq,num_frames,im_width,im_height,frame_rate`` (header line required).
    """
    text = read_text(csv_path)
    reader = csv.DictReader(io.StringIO(text))
    try:
        return _kitti_seqinfo_rows(csv_path, reader)
    except csv.Error as exc:  # a field past the csv module's limit, a NUL ...
        raise InputError(f"not a valid CSV file: {exc}", csv_path, reader.line_num + 1) from None


def _kitti_seqinfo_rows(csv_path: PathLike, reader: csv.DictReader) -> dict[str, SequenceInfo]:
    fields = [f.strip() for f in reader.fieldnames or []]
    missing = [c for c in _SEQINFO_COLUMNS if c not in fields]
    if missing:
        raise InputError(
            f"header must name columns {', '.join(_SEQINFO_COLUMNS)}; missing "
            f"{', '.join(missing)}",
            csv_path,
            1,
        )
    reader.fieldnames = fields
    out: dict[str, SequenceInfo] = {}
    for row in reader:
        line = reader.line_num
        if not any((v or "").strip() for v in row.values()):
            continue
        values: dict[str, float] = {}
        for key in _SEQINFO_COLUMNS[1:]:
            raw = (row.get(key) or "").strip()
            try:
                value = float(raw) if key == "frame_rate" else int(raw)
            except ValueError:
                raise InputError(
                    f"{key} must be {'a number' if key == 'frame_rate' else 'an integer'}"
                    f", got {raw!r}",
                    csv_path,
                    line,
                ) from None
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"{key} must be positive, got {raw!r}", csv_path, line)
            if key == "num_frames":
                check_sequence_length(value, key, csv_path, line)
            values[key] = value
        name = (row.get("seq") or "").strip()
        if not name:
            raise InputError("empty sequence name", csv_path, line)
        if name in out:
            raise InputError(f"sequence {name!r} listed twice", csv_path, line)
        out[name] = SequenceInfo(
            name=name,
            length=int(values["num_frames"]),
            width=int(values["im_width"]),
            height=int(values["im_height"]),
            fps=float(values["frame_rate"]),
        )
    return out


def read_kitti_labels(path: PathLike) -> Detections:
    """Read KITTI ``label_02`` ground truth or tracking results (17 fields, or 18 with a score).

    ``frame id type truncated occluded alpha x1 y1 x2 y2 h w l X Y Z rot_y [score]``. ``type`` ->
    ``class_id`` (``DontCare`` -> 19, its id -1 kept as ``tracker_id`` -1); score ->
    ``confidence`` (1.0 when absent). ``data``: ``"truncated"`` (N,) float, ``"occluded"`` (N,)
    int, ``"alpha"`` (N,) rad, ``"dimensions"`` (N, 3) h, w, l in m, ``"location"`` (N, 3)
    X, Y, Z in m (camera frame), ``"rotation_y"`` (N,) rad. Any line order; returned sorted by
    (frame, id). An empty file gives empty Detections.
    """
    table = parse_table(path, sep=None, names=KITTI_LABEL_LAYOUTS, text_cols=(2,))
    dets = kitti_labels_from_table(table)
    assert dets.tracker_id is not None and dets.frame is not None  # set by __post_init__
    return dets[np.lexsort((dets.tracker_id, dets.frame))]


def kitti_labels_from_table(table: Table) -> Detections:
    """:func:`read_kitti_labels` of an already parsed table, in the table's line order."""
    n = len(table)
    if n == 0:
        return Detections(
            xyxy=np.zeros((0, 4)), data=_label_data(np.zeros((0, 17)), np.zeros(0, np.int64))
        )
    frames = table.integers(
        0, minimum=0, maximum=MAX_FRAME, maximum_why=" (sensemaking.detections.MAX_FRAME)"
    )
    ids = table.integers(1, minimum=-1)
    table.finite([c for c in range(3, table.ncols) if c != 4])
    occluded = table.integers(4)
    types, inverse = np.unique(np.asarray(table.texts[2]), return_inverse=True)
    inverse = inverse.reshape(-1)
    lookup = np.full(len(types), -1, dtype=np.int64)
    for k, name in enumerate(types.tolist()):
        try:
            lookup[k] = class_id(name)
        except KeyError:
            pass  # stays -1: reported below at its first line
    if (lookup < 0).any():
        i = int(np.argmax(lookup[inverse] < 0))
        table.fail(
            i,
            f"unknown object type {table.texts[2][i]!r} "
            f"(KITTI types: {', '.join(KITTI_NAMES.values())})",
        )
    v = table.values
    table.positive_size(v[:, 8] - v[:, 6], v[:, 9] - v[:, 7])
    dets = Detections(
        xyxy=v[:, 6:10],
        confidence=v[:, 17] if table.ncols == 18 else None,
        class_id=lookup[inverse],
        tracker_id=ids,
        frame=frames,
        source_row=table.rows,
        data=_label_data(v, occluded),
    )
    return dets


def _label_data(v: np.ndarray, occluded: np.ndarray) -> dict[str, np.ndarray]:
    return {
        "truncated": v[:, 3].copy(),
        "occluded": occluded,
        "alpha": v[:, 5].copy(),
        "dimensions": v[:, 10:13].copy(),
        "location": v[:, 13:16].copy(),
        "rotation_y": v[:, 16].copy(),
    }


def write_kitti(path: PathLike, tracks: Detections) -> None:
    """Write KITTI tracking results (18 fields incl. score) atomically, sorted by frame.

    Uses ``data`` columns ``truncated``, ``occluded``, ``alpha``, ``dimensions``, ``location``,
    ``rotation_y`` when present, else KITTI's placeholders (-1, -1, -10, -1 -1 -1,
    -1000 -1000 -1000, -10). Every class needs a KITTI type name
    (:data:`~sensemaking.classes.KITTI_NAMES`).
    Lossless: :func:`read_kitti_labels` gives back the same arrays bit for bit.
    """
    text = format_kitti(tracks, path)
    with atomic_write(path) as handle:
        handle.write(text)


def format_kitti(tracks: Detections, path: PathLike | None = None) -> str:
    """The lines :func:`write_kitti` writes (sorted by frame, stable); ``path`` names the file in
    errors. Frame by frame, the pieces of a frame-ordered run join to the same text as the
    whole."""
    n = len(tracks)
    assert tracks.frame is not None and tracks.tracker_id is not None  # set by __post_init__
    assert tracks.class_id is not None and tracks.confidence is not None
    names = {}
    for cid in np.unique(tracks.class_id).tolist():
        if cid not in KITTI_NAMES:
            raise InputError(
                f"class {cid} ({_class_name(cid)}) has no KITTI type name; KITTI types are "
                f"{', '.join(f'{k} ({v})' for k, v in KITTI_NAMES.items())}",
                path,
            )
        names[cid] = KITTI_NAMES[cid]
    if n and not np.isfinite(tracks.xyxy).all():
        raise ValueError("cannot write boxes with non-finite coordinates")

    order = frame_order(tracks.frame)

    def column(key: str, default: float, width: int = 0) -> list[list[str]]:
        """Text of data column ``key`` (sorted by frame), one list per component."""
        shape = (n, width) if width else (n,)
        value = tracks.data.get(key)
        if value is None:
            return [[num(default)] * n for _ in range(max(width, 1))]
        value = np.asarray(value, dtype=np.float64)
        if value.shape != shape:
            raise ValueError(
                f"Detections.data[{key!r}] must have shape {shape}, got {value.shape}"
            )
        value = value[order].reshape(n, max(width, 1))
        return [nums(value[:, k]) for k in range(value.shape[1])]

    xyxy = tracks.xyxy[order]
    cols = zip(
        ints(tracks.frame[order]),
        ints(tracks.tracker_id[order]),
        [names[c] for c in tracks.class_id[order].tolist()],
        *column("truncated", -1.0),
        *column("occluded", -1.0),
        *column("alpha", -10.0),
        *(nums(xyxy[:, k]) for k in range(4)),
        *column("dimensions", -1.0, 3),
        *column("location", -1000.0, 3),
        *column("rotation_y", -10.0),
        nums(tracks.confidence[order]),
        strict=True,
    )
    return "".join(" ".join(fields) + "\n" for fields in cols)


def read_kitti_detections(path: PathLike, class_name: str | None = None) -> Detections:
    """Read KITTI 2D detections, sorted by frame (the file must be), frames 0-based.

    RRC ``frame,x1,y1,x2,y2,score``: one class per file, from ``class_name`` or else the parent
    folder's name (``.../rrc/car/0000.txt`` -> car). PointRCNN
    ``frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha``: class from ``type`` (1 pedestrian,
    2 car, 3 cyclist; ``class_name`` is not used), the score (a logit) mapped through the
    sigmoid to a probability as ``confidence``, ``data`` ``"dimensions"`` (N, 3),
    ``"location"`` (N, 3), ``"rotation_y"`` (N,), ``"alpha"`` (N,) as in
    :func:`read_kitti_labels`. Boxes of zero width or height are dropped with a warning. An
    empty file (no detections in the whole sequence) gives empty Detections.
    """
    return kitti_detections_from_table(
        parse_table(path, sep=",", names=KITTI_DETECTION_LAYOUTS), class_name
    )


#: comma-separated KITTI detection files: number of fields -> column names (RRC, PointRCNN)
KITTI_DETECTION_LAYOUTS = {6: _RRC_NAMES, 15: _POINTRCNN_NAMES}
#: KITTI label / tracking-result files (space-separated, type in column 2)
KITTI_LABEL_LAYOUTS = {17: _LABEL_NAMES[:17], 18: _LABEL_NAMES}


def kitti_detections_from_table(
    table: Table, class_name: str | None = None, logger: logging.Logger | None = log
) -> Detections:
    """:func:`read_kitti_detections` of an already parsed table (a whole file or a chunk)."""
    path = table.path
    if len(table) == 0:
        return Detections.empty()
    frames = table.integers(
        0, minimum=0, maximum=MAX_FRAME, maximum_why=" (sensemaking.detections.MAX_FRAME)"
    )
    v = table.values
    if table.ncols == 6:  # RRC
        cid = _rrc_class(path, class_name)
        table.finite(range(1, 6))
        box, score, data = v[:, 1:5], v[:, 5], {}
        classes = np.full(len(table), cid, dtype=np.int64)
    else:  # PointRCNN
        codes = table.integers(1)
        bad = ~np.isin(codes, list(_POINTRCNN_CLASSES))
        if bad.any():
            table.fail(
                int(np.argmax(bad)),
                f"unknown PointRCNN type {codes[bad][0]} "
                "(expected 1 pedestrian, 2 car or 3 cyclist)",
            )
        table.finite(range(2, 15))
        # the raw scores are logits: as probabilities, score thresholds mean the same for every
        # detector (every reader, the benchmark runner's and track's, reads through here)
        box, score = v[:, 2:6], expit(v[:, 6])
        lookup = np.zeros(max(_POINTRCNN_CLASSES) + 1, dtype=np.int64)
        lookup[list(_POINTRCNN_CLASSES)] = list(_POINTRCNN_CLASSES.values())
        classes = lookup[codes]
        data = {
            "dimensions": v[:, 7:10].copy(),
            "location": v[:, 10:13].copy(),
            "rotation_y": v[:, 13].copy(),
            "alpha": v[:, 14].copy(),
        }
    table.sorted_frames(frames)
    keep = table.positive_size(
        box[:, 2] - box[:, 0], box[:, 3] - box[:, 1], drop_zero=True, logger=logger
    )
    dets = Detections(
        xyxy=box,
        confidence=score,
        class_id=classes,
        frame=frames,
        source_row=table.rows,
        data=data,
    )
    return dets if keep.all() else dets[keep]


def _rrc_class(path: PathLike, name: str | None) -> int:
    """Class id of an RRC file: ``name``, else the parent folder's name."""
    if name is not None:
        return class_id_of(name, path)
    folder = Path(path).resolve().parent.name
    try:
        return class_id(folder)
    except KeyError:
        raise InputError(
            f"cannot tell the class of these RRC detections: folder {folder!r} is not a class "
            "name; pass class_name (e.g. --class car)",
            path,
        ) from None

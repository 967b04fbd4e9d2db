"""Detections from other libraries' detector outputs, without importing those libraries.

* :func:`from_supervision` — a ``supervision.Detections`` (or anything with ``.xyxy``,
  ``.confidence``, ``.class_id``, ``.data``).
* :func:`from_ultralytics` — one ultralytics ``Results`` (``.boxes.xyxy/.conf/.cls`` as torch
  tensors or numpy arrays, ``.names``).
* :func:`as_detections` — dispatches on the type; :meth:`Tracker.update` calls it, so the tracker
  accepts all of these (and plain ``(N, 4|5|6)`` arrays) directly.
* :func:`to_supervision` — our Detections as a ``supervision.Detections`` (needs supervision).

Detector class names are mapped into :mod:`sensemaking.classes` by :func:`map_class_name`: our
own names (any spelling :func:`~sensemaking.classes.class_id` accepts: ``Car``, ``Pedestrian``,
``Cyclist``...) map to themselves, and these COCO names are translated (see ``docs/detectors.md``):

=============  ============  ==========================================================
COCO name      our class     why
=============  ============  ==========================================================
person         pedestrian    COCO has one class for every person
bicycle        bicycle       a rider and their bicycle stay two objects (no merging)
motorcycle     motorbike
bus            truck         no bus class: the nearest large vehicle (an occluder)
train          tram          rail vehicle
=============  ============  ==========================================================

Any other name maps to 0 (unknown class). The detector's own class id and name are always kept
in ``data["source_class_id"]`` and ``data["class_name"]``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sensemaking.classes import CLASS_NAMES, class_id
from sensemaking.detections import Detections

__all__ = [
    "COCO_ALIASES",
    "map_class_name",
    "from_supervision",
    "from_ultralytics",
    "from_array",
    "to_supervision",
    "as_detections",
]

#: detector names (lower case) that are not our class names, and the class they map to
COCO_ALIASES: dict[str, str] = {
    "person": "pedestrian",
    "people": "pedestrian",
    "motorcycle": "motorbike",
    "bus": "truck",
    "train": "tram",
    "rider": "cyclist",
}


def map_class_name(name: str) -> int:
    """Our class id for a detector's class name (see the module table); 0 when nothing matches."""
    key = str(name).strip().lower().replace(" ", "_").replace("-", "_")
    key = COCO_ALIASES.get(key, key)
    try:
        return class_id(key)
    except KeyError:
        return 0


def _numpy(value: Any, dtype: Any = None) -> np.ndarray | None:
    """A numpy array from a numpy array, list or (CPU/GPU, grad or not) torch tensor; None stays
    None."""
    return None if value is None else _array(value, dtype)


def _array(value: Any, dtype: Any = None) -> np.ndarray:
    """A numpy array from a numpy array, list or (CPU/GPU, grad or not) torch tensor."""
    if hasattr(value, "detach"):
        value = value.detach()
    if hasattr(value, "cpu"):
        value = value.cpu()
    if hasattr(value, "numpy"):
        value = value.numpy()
    return np.asarray(value, dtype=dtype)


def _names_lookup(names: Mapping[int, str] | Sequence[str] | None) -> dict[int, str]:
    if names is None:
        return {}
    if isinstance(names, Mapping):
        return {int(k): str(v) for k, v in names.items()}
    return {i: str(v) for i, v in enumerate(names)}


def _map_ids(
    source_ids: np.ndarray, names: dict[int, str], class_map: Mapping[int, int | str] | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Our class ids (and the detector's names, or None) for the detector's class ids."""
    uniq = np.unique(source_ids)
    table: dict[int, int] = {}
    for sid in uniq.tolist():
        if class_map is not None and sid in class_map:
            target = class_map[sid]
            table[sid] = (
                target if isinstance(target, (int, np.integer)) else map_class_name(str(target))
            )
        elif sid in names:
            table[sid] = map_class_name(names[sid])
        else:
            table[sid] = 0
    ours = np.array([table[s] for s in source_ids.tolist()], dtype=np.int64)
    cls_names = None
    if names:
        cls_names = np.array([names.get(s, "") for s in source_ids.tolist()], dtype=object)
    return ours, cls_names


def _finish(
    xyxy: np.ndarray,
    confidence: np.ndarray | None,
    source_ids: np.ndarray | None,
    names: dict[int, str],
    class_map: Mapping[int, int | str] | None,
    frame: int | None,
    drop_unknown: bool,
    extra: dict[str, np.ndarray] | None = None,
    class_names: np.ndarray | None = None,
) -> Detections:
    n = xyxy.shape[0]
    data: dict[str, np.ndarray] = dict(extra or {})
    if source_ids is None:
        ours = np.zeros(n, dtype=np.int64)
        if class_names is not None:
            ours = np.array([map_class_name(c) for c in class_names.tolist()], dtype=np.int64)
    else:
        source_ids = source_ids.astype(np.int64).reshape(-1)
        if class_names is not None and not names:
            # per-box names (supervision's data["class_name"]) give the mapping
            names = {
                int(s): str(c)
                for s, c in zip(source_ids.tolist(), class_names.tolist(), strict=True)
            }
        ours, cls_names = _map_ids(source_ids, names, class_map)
        data["source_class_id"] = source_ids
        if cls_names is not None and class_names is None:
            class_names = cls_names
    if class_names is not None:
        data["class_name"] = np.asarray(class_names, dtype=object)
    det = Detections(
        xyxy=xyxy,
        confidence=confidence,
        class_id=ours,
        frame=0 if frame is None else int(frame),
        data=data,
    )
    if drop_unknown and n:
        det = det[det.class_id != 0]
    return det


def from_supervision(
    det: Any,
    *,
    class_map: Mapping[int, int | str] | None = None,
    names: Mapping[int, str] | Sequence[str] | None = None,
    frame: int | None = None,
    drop_unknown: bool = False,
) -> Detections:
    """Our Detections from a ``supervision.Detections`` (duck-typed).

    Args:
        det: has ``xyxy`` (N, 4) px, ``confidence`` (N,) or None, ``class_id`` (N,) or None and
            ``data`` (dict; ``data["class_name"]`` names each box's class when present).
        class_map: detector class id -> our class id or name; takes precedence over names.
        names: detector class id -> name (e.g. ``model.names``) when ``data`` has no class names.
        frame: frame number stored in every box (default 0).
        drop_unknown: drop boxes whose class maps to 0 (unknown).
    Returns:
        Detections with our class ids; ``data`` keeps ``source_class_id``, ``class_name`` and
        supervision's other per-box ``data`` columns. ``tracker_id`` is not carried over.
    """
    xyxy = _array(det.xyxy, np.float64).reshape(-1, 4)
    n = xyxy.shape[0]
    conf = _numpy(getattr(det, "confidence", None), np.float64)
    cls = _numpy(getattr(det, "class_id", None))
    data_in = dict(getattr(det, "data", None) or {})
    class_names = data_in.pop("class_name", None)
    class_names = (
        None if class_names is None else np.asarray(class_names, dtype=object).reshape(-1)
    )
    extra = {}
    for key, value in data_in.items():
        arr = _numpy(value) if not isinstance(value, np.ndarray) else value
        if arr is not None and arr.ndim >= 1 and arr.shape[0] == n:
            extra[key] = arr
    return _finish(
        xyxy, conf, cls, _names_lookup(names), class_map, frame, drop_unknown, extra, class_names
    )


def from_ultralytics(
    result: Any,
    *,
    class_map: Mapping[int, int | str] | None = None,
    frame: int | None = None,
    drop_unknown: bool = False,
) -> Detections:
    """Our Detections from one ultralytics ``Results`` (duck-typed; torch tensors or arrays).

    Args:
        result: has ``boxes`` with ``xyxy`` (N, 4) px in the original image, ``conf`` (N,) and
            ``cls`` (N,), and ``names`` (class id -> name). A list of one Results is accepted.
        class_map, frame, drop_unknown: as in :func:`from_supervision`.
    """
    if isinstance(result, (list, tuple)):
        if len(result) != 1:
            raise ValueError(f"expected one ultralytics Results (one image), got {len(result)}")
        result = result[0]
    boxes = getattr(result, "boxes", None)
    if boxes is None:
        raise ValueError("this ultralytics result has no boxes (not a detection model?)")
    xyxy = _array(boxes.xyxy, np.float64).reshape(-1, 4)
    conf = _numpy(getattr(boxes, "conf", None), np.float64)
    cls = _numpy(getattr(boxes, "cls", None))
    cls = None if cls is None else np.rint(cls.astype(np.float64)).astype(np.int64)
    names = _names_lookup(getattr(result, "names", None))
    return _finish(
        xyxy,
        None if conf is None else conf.reshape(-1),
        cls,
        names,
        class_map,
        frame,
        drop_unknown,
    )


def from_array(array: Any, *, frame: int | None = None) -> Detections:
    """Detections from an ``(N, 4|5|6)`` array: ``x1, y1, x2, y2[, confidence[, class_id]]``.

    The class id column (float or int) is taken to be one of *our* ids
    (:mod:`sensemaking.classes`).
    """
    arr = _array(array, np.float64)
    if arr.size == 0:
        det = Detections.empty()
        return det if frame is None else det.with_(frame=np.full(0, frame))
    if arr.ndim != 2 or arr.shape[1] not in (4, 5, 6):
        raise ValueError(
            f"an array of detections must have shape (N, 4), (N, 5) or (N, 6), got {arr.shape}"
        )
    return Detections(
        xyxy=arr[:, :4],
        confidence=arr[:, 4] if arr.shape[1] >= 5 else None,
        class_id=np.rint(arr[:, 5]).astype(np.int64) if arr.shape[1] == 6 else None,
        frame=0 if frame is None else int(frame),
    )


def _is_ultralytics(obj: Any) -> bool:
    boxes = getattr(obj, "boxes", None)
    return boxes is not None and hasattr(boxes, "xyxy")


def as_detections(obj: Any, *, frame: int | None = None) -> Detections:
    """Detections from whatever a detector gave: the tracker's single entry point.

    Accepts our :class:`~sensemaking.detections.Detections` (returned as is, or with ``frame``
    set when given), ``None`` (no boxes), an ultralytics ``Results`` or a list of one, a
    supervision-like object (``.xyxy`` plus ``.confidence``/``.class_id``), or an array-like of
    shape ``(N, 4|5|6)`` (:func:`from_array`). Raises TypeError for anything else.
    """
    if isinstance(obj, Detections):
        if frame is not None and (len(obj) == 0 or np.any(obj.frame != frame)):
            return obj.with_(frame=np.full(len(obj), int(frame), dtype=np.int64))
        return obj
    if obj is None:
        return from_array(np.zeros((0, 4)), frame=frame)
    if _is_ultralytics(obj):
        return from_ultralytics(obj, frame=frame)
    if isinstance(obj, (list, tuple)) and len(obj) == 1 and _is_ultralytics(obj[0]):
        return from_ultralytics(obj[0], frame=frame)
    if hasattr(obj, "xyxy") and (hasattr(obj, "confidence") or hasattr(obj, "class_id")):
        return from_supervision(obj, frame=frame)
    if (
        isinstance(obj, (np.ndarray, list, tuple))
        or hasattr(obj, "__array__")
        or hasattr(obj, "numpy")
    ):
        try:
            return from_array(obj, frame=frame)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"cannot use this {type(obj).__name__} as detections: {exc}") from exc
    raise TypeError(
        f"cannot use a {type(obj).__name__} as detections: give sensemaking Detections, a "
        "supervision Detections, an ultralytics Results or an (N, 4|5|6) array"
    )


def to_supervision(detections: Detections) -> Any:
    """Our Detections as a ``supervision.Detections`` (needs the ``supervision`` package).

    ``class_id`` stays our vocabulary; ``data`` gets ``class_name`` (our names), ``frame``,
    ``source_row`` and every column of our ``data`` (``state``, ``occluder``...).
    """
    try:
        import supervision as sv
    except ImportError as exc:
        raise ImportError(
            "to_supervision needs the 'supervision' package: pip install supervision"
        ) from exc
    data: dict[str, np.ndarray | list[Any]] = {
        k: np.asarray(v) for k, v in detections.data.items()
    }
    data.setdefault(
        "class_name",
        np.array(
            [CLASS_NAMES.get(int(c), f"class{int(c)}") for c in detections.class_id], dtype=object
        ).astype(str)
        if len(detections)
        else np.array([], dtype=str),
    )
    data["frame"] = detections.frame.copy()
    data["source_row"] = detections.source_row.copy()
    tracker_id = detections.tracker_id.copy() if np.any(detections.tracker_id >= 0) else None
    return sv.Detections(
        xyxy=detections.xyxy.astype(np.float32),
        confidence=detections.confidence.astype(np.float32),
        class_id=detections.class_id.astype(int),
        tracker_id=tracker_id,
        data=data,
    )

"""Run a local detector model on images: ONNX (YOLO-style exports) or ultralytics ``.pt``.

:func:`load_detector` returns a callable ``detector(image) -> Detections`` for an ``H x W x 3``
uint8 **RGB** image. Nothing is ever downloaded: the model file must exist locally. Formats and
class-name mapping are documented in ``docs/detectors.md``. Needs the ``detector`` extra
(``onnxruntime`` for ONNX, ``ultralytics`` for ``.pt``); videos need the ``viz`` extra.
"""

from __future__ import annotations

import ast
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import numpy as np

from sensemaking.adapters import from_ultralytics, map_class_name
from sensemaking.detections import Detections
from sensemaking.errors import InputError, require
from sensemaking.io.media import iter_video_frames  # noqa: F401  (re-exported; frames are read in io)

__all__ = [
    "Detector",
    "OnnxDetector",
    "UltralyticsDetector",
    "load_detector",
    "iter_video_frames",
    "nms",
]

Layout = Literal["auto", "yolov8", "yolov8_rows", "yolov5", "end2end"]
LAYOUTS = ("auto", "yolov8", "yolov8_rows", "yolov5", "end2end")


class Detector:
    """A loaded model: ``detector(image, frame=0) -> Detections`` (boxes in image pixels)."""

    path: Path
    names: dict[int, str]

    def __call__(self, image: np.ndarray, frame: int = 0) -> Detections:  # pragma: no cover
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({str(self.path)!r}, {len(self.names)} classes)"


def load_detector(
    path: str | os.PathLike[str],
    *,
    conf: float = 0.25,
    iou: float = 0.45,
    input_size: int | tuple[int, int] | None = None,
    layout: Layout = "auto",
    names: Mapping[int, str] | None = None,
    drop_unknown: bool = False,
    providers: list[str] | None = None,
) -> Detector:
    """Load a local detector model; returns
    ``detector(image HxWx3 uint8 RGB, frame=0) -> Detections``.

    Args:
        path: ``.onnx`` (run with onnxruntime) or ``.pt`` (run with ultralytics). Never downloaded.
        conf: drop boxes scoring below this (0-1).
        iou: class-wise non-maximum suppression IoU threshold (not applied to end-to-end outputs).
        input_size: ONNX network input ``(height, width)`` or one int for square; default: the
            model's fixed input shape, else 640.
        layout: ONNX output layout; ``auto`` infers it (see ``docs/detectors.md``).
        names: class id -> name, overriding the names stored in the model.
        drop_unknown: drop boxes whose class has no match in :mod:`sensemaking.classes`.
        providers: onnxruntime execution providers (default: CPU only).
    Raises:
        InputError: the file does not exist or has an unknown suffix.
        MissingExtraError: onnxruntime / ultralytics is not installed.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("no such model file (models are never downloaded; give a local file)", p)
    suffix = p.suffix.lower()
    if suffix == ".onnx":
        return OnnxDetector(
            p,
            conf=conf,
            iou=iou,
            input_size=input_size,
            layout=layout,
            names=names,
            drop_unknown=drop_unknown,
            providers=providers,
        )
    if suffix == ".pt":
        return UltralyticsDetector(p, conf=conf, iou=iou, names=names, drop_unknown=drop_unknown)
    raise InputError(f"unknown model type {suffix!r}: give an .onnx or an ultralytics .pt file", p)


# ONNX ------------------------------------------------------------------------------------------
def _names_from_metadata(meta: Mapping[str, str]) -> dict[int, str]:
    """Class names stored by an ultralytics export (``names`` = ``"{0: 'person', ...}"``)."""
    text = meta.get("names")
    if not text:
        return {}
    try:
        value = ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return {}
    if isinstance(value, dict):
        return {int(k): str(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return {i: str(v) for i, v in enumerate(value)}
    return {}


def nms(xyxy: np.ndarray, scores: np.ndarray, classes: np.ndarray, iou: float) -> np.ndarray:
    """Indices kept by class-wise greedy non-maximum suppression, by decreasing score.

    Args: xyxy (N, 4) px; scores (N,); classes (N,) int; iou: suppression threshold in [0, 1].
    """
    if len(scores) == 0:
        return np.zeros(0, dtype=np.int64)
    # offset boxes per class so different classes never overlap
    offset = classes.astype(np.float64)[:, None] * (float(np.max(xyxy)) + 1.0)
    boxes = xyxy + offset
    x1, y1, x2, y2 = boxes.T
    areas = np.clip(x2 - x1, 0, None) * np.clip(y2 - y1, 0, None)
    order = np.argsort(-scores, kind="stable")
    keep = []
    while order.size:
        i = order[0]
        keep.append(i)
        rest = order[1:]
        w = np.clip(np.minimum(x2[i], x2[rest]) - np.maximum(x1[i], x1[rest]), 0, None)
        h = np.clip(np.minimum(y2[i], y2[rest]) - np.maximum(y1[i], y1[rest]), 0, None)
        inter = w * h
        union = areas[i] + areas[rest] - inter
        ov = np.where(union > 0, inter / np.where(union > 0, union, 1), 0)
        order = rest[ov <= iou]
    return np.asarray(keep, dtype=np.int64)


def _letterbox(
    image: np.ndarray, size: tuple[int, int]
) -> tuple[np.ndarray, float, tuple[float, float]]:
    """Resize keeping aspect into ``size = (h, w)``, pad with grey 114; returns
    (img, gain, (padx, pady))."""
    pil = require("PIL.Image", "detector")
    h0, w0 = image.shape[:2]
    th, tw = size
    gain = min(th / h0, tw / w0)
    nw, nh = max(int(round(w0 * gain)), 1), max(int(round(h0 * gain)), 1)
    resized = image
    if (nw, nh) != (w0, h0):
        resized = np.asarray(pil.fromarray(image).resize((nw, nh), pil.Resampling.BILINEAR))
    padx, pady = (tw - nw) / 2, (th - nh) / 2
    out = np.full((th, tw, 3), 114, dtype=np.uint8)
    top, left = int(round(pady - 0.1)), int(round(padx - 0.1))
    out[top : top + nh, left : left + nw] = resized
    return out, gain, (left, top)


def _guess_layout(out: np.ndarray, nc: int | None) -> str | None:
    """The layout of a 2-D raw output (see docs/detectors.md), or None when it cannot be told."""
    rows, cols = out.shape
    if rows < cols and (nc is None or rows == 4 + nc):
        return "yolov8"  # (4 + nc, N), the usual ultralytics export
    if nc is not None and rows == 4 + nc and cols not in (6, 4 + nc, 5 + nc):
        return "yolov8"  # the same with fewer than 4 + nc candidates
    if cols == 6 and nc == 1:
        # YOLOv5 with one class or end-to-end: end-to-end rows are corners and integer classes
        x1, y1, x2, y2, cls = out[:, 0], out[:, 1], out[:, 2], out[:, 3], out[:, 5]
        corners = bool(np.all((x2 >= x1) & (y2 >= y1)))
        return (
            "end2end"
            if corners and np.all(cls == np.round(cls)) and np.all(cls >= 0)
            else "yolov5"
        )
    if cols == 6:
        return "end2end"  # (N, 6): x1, y1, x2, y2, score, class
    if nc is not None and cols == 5 + nc:
        return "yolov5"
    if nc is not None and cols == 4 + nc:
        return "yolov8_rows"
    return None


class OnnxDetector(Detector):
    """A YOLO-style ONNX export run with onnxruntime (CPU by default)."""

    def __init__(
        self,
        path: Path,
        *,
        conf: float = 0.25,
        iou: float = 0.45,
        input_size: int | tuple[int, int] | None = None,
        layout: Layout = "auto",
        names: Mapping[int, str] | None = None,
        drop_unknown: bool = False,
        providers: list[str] | None = None,
    ):
        if layout not in LAYOUTS:
            raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
        ort = require("onnxruntime", "detector")
        self.path = Path(path)
        self.conf, self.iou, self.layout, self.drop_unknown = (
            float(conf),
            float(iou),
            layout,
            drop_unknown,
        )
        try:
            self.session = ort.InferenceSession(
                str(self.path), providers=providers or ["CPUExecutionProvider"]
            )
        except Exception as exc:  # noqa: BLE001 - onnxruntime's errors (a corrupt model) vary
            from sensemaking.errors import InputError

            why = " ".join(str(exc).split())[:300]
            raise InputError(f"not a usable ONNX model: {why}", self.path) from None
        inp = self.session.get_inputs()[0]
        self.input_name = inp.name
        shape = list(inp.shape)
        if input_size is None:
            fixed = [d if isinstance(d, int) and d > 0 else None for d in shape[2:4]]
            input_size = (fixed[0] or 640, fixed[1] or 640) if len(fixed) == 2 else (640, 640)
        self.input_size = (
            (int(input_size), int(input_size))
            if isinstance(input_size, int)
            else (int(input_size[0]), int(input_size[1]))
        )
        meta = self.session.get_modelmeta().custom_metadata_map or {}
        self.names = dict(names) if names is not None else _names_from_metadata(meta)
        self._class_ids = {k: map_class_name(v) for k, v in self.names.items()}

    def _decode(self, out: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """(xyxy in network pixels, scores, class ids, already suppressed) from the raw output."""
        out = np.asarray(out, dtype=np.float32)
        if out.ndim == 3:
            out = out[0]
        if out.ndim != 2:
            raise InputError(f"unexpected ONNX output shape {out.shape}", self.path)
        nc = len(self.names) or None
        layout: str | None = self.layout
        if layout == "auto":
            layout = _guess_layout(out, nc)
            if layout is None:
                raise InputError(
                    f"cannot tell the layout of the ONNX output {out.shape} with "
                    f"{nc or 'unknown'} classes: pass layout=",
                    self.path,
                )
        if layout == "end2end":
            return out[:, :4], out[:, 4], np.rint(out[:, 5]).astype(np.int64), True
        if layout == "yolov8":
            out = out.T
        if layout == "yolov5":
            cls_scores = out[:, 5:] * out[:, 4:5]
        else:
            cls_scores = out[:, 4:]
        cls = (
            np.argmax(cls_scores, axis=1)
            if cls_scores.shape[1]
            else np.zeros(len(out), dtype=np.int64)
        )
        scores = cls_scores[np.arange(len(out)), cls] if cls_scores.shape[1] else np.ones(len(out))
        cx, cy, w, h = out[:, 0], out[:, 1], out[:, 2], out[:, 3]
        xyxy = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1)
        return xyxy, scores, cls.astype(np.int64), False

    def __call__(self, image: np.ndarray, frame: int = 0) -> Detections:
        """Detections of one ``H x W x 3`` uint8 RGB image (boxes clipped to the image)."""
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(f"expected an H x W x 3 RGB image, got shape {image.shape}")
        if image.dtype != np.uint8:
            image = np.clip(image, 0, 255).astype(np.uint8)
        boxed, gain, (padx, pady) = _letterbox(image, self.input_size)
        blob = (boxed.transpose(2, 0, 1)[None].astype(np.float32)) / 255.0
        out = self.session.run(None, {self.input_name: blob})[0]
        xyxy, scores, cls, suppressed = self._decode(out)
        keep = scores >= self.conf
        xyxy, scores, cls = (
            xyxy[keep].astype(np.float64),
            scores[keep].astype(np.float64),
            cls[keep],
        )
        if not suppressed and len(scores):
            idx = nms(xyxy, scores, cls, self.iou)
            xyxy, scores, cls = xyxy[idx], scores[idx], cls[idx]
        xyxy = (xyxy - np.array([padx, pady, padx, pady])) / gain
        h, w = image.shape[:2]
        xyxy[:, [0, 2]] = np.clip(xyxy[:, [0, 2]], 0, w)
        xyxy[:, [1, 3]] = np.clip(xyxy[:, [1, 3]], 0, h)
        ok = (xyxy[:, 2] > xyxy[:, 0]) & (xyxy[:, 3] > xyxy[:, 1])
        xyxy, scores, cls = xyxy[ok], scores[ok], cls[ok]
        ours = np.array([self._class_ids.get(int(c), 0) for c in cls], dtype=np.int64)
        data = {"source_class_id": cls.astype(np.int64)}
        if self.names:
            data["class_name"] = np.array([self.names.get(int(c), "") for c in cls], dtype=object)
        det = Detections(
            xyxy=xyxy.reshape(-1, 4), confidence=scores, class_id=ours, frame=int(frame), data=data
        )
        if self.drop_unknown and len(det):
            det = det[det.class_id != 0]
        return det


# ultralytics ------------------------------------------------------------------------------------
class UltralyticsDetector(Detector):
    """An ultralytics ``.pt`` model (YOLOv5u/v8/v11...) loaded from a local file."""

    def __init__(
        self,
        path: Path,
        *,
        conf: float = 0.25,
        iou: float = 0.45,
        names: Mapping[int, str] | None = None,
        drop_unknown: bool = False,
    ):
        ultralytics = require("ultralytics", "ultralytics")
        self.path = Path(path).resolve()
        self.conf, self.iou, self.drop_unknown = float(conf), float(iou), drop_unknown
        # an absolute path of an existing file: ultralytics loads it and downloads nothing
        self.model = ultralytics.YOLO(str(self.path))
        self.names = (
            dict(names)
            if names is not None
            else {int(k): str(v) for k, v in dict(self.model.names).items()}
        )

    def __call__(self, image: np.ndarray, frame: int = 0) -> Detections:
        """Detections of one ``H x W x 3`` uint8 RGB image."""
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(f"expected an H x W x 3 RGB image, got shape {image.shape}")
        # ultralytics reads numpy images as BGR (OpenCV order)
        results = self.model.predict(
            np.ascontiguousarray(image[..., ::-1]), conf=self.conf, iou=self.iou, verbose=False
        )
        result = results[0]
        if self.names and getattr(result, "names", None) != self.names:
            try:
                result.names = self.names
            except AttributeError:  # pragma: no cover - read-only in some versions
                pass
        return from_ultralytics(result, frame=frame, drop_unknown=self.drop_unknown)

"""How far ahead a motion model predicts a real object's box (issue 27: the pinhole filter).

Tracker-free: for each ground-truth object of a shared sequence, its own detections (the best
one with IoU >= 0.5 on each frame it is visible -- KITTI ``occluded <= 1``, MOT17 visibility
>= 0.5 -- and scoring at least the preset's ``min_confidence``) are fed to one filter of the
preset's Kalman settings (``--set`` changes them: ``kalman.perspective=true``, its
``depth_noise``, ``velocity_std``); from every frame after its third detection the box is
predicted 0.2, 0.5 and 1 s ahead and compared (IoU) with the ground truth there, visible or
not. "young": the next frame's box predicted after the object's first and second detection, as
a new track's is. What an association gate sees, without the tracker's own choices in the way.

    python benchmarks/motion_prediction.py [--data DIR] [--only BENCH] [--set KEY=VALUE ...]

Prints per benchmark (and per sequence with ``--per-sequence``): the mean IoU at each horizon
and, after the slash, the share of predictions with IoU >= 0.3.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from occlusion_errors import BENCHMARKS, DATA, Item, _fps, _gt, _iou, items

from sensemaking.classes import class_id
from sensemaking.detections import Detections
from sensemaking.io.kitti import read_kitti_detections, read_kitti_seqinfo
from sensemaking.io.mot import read_mot, read_seqinfo
from sensemaking.motion import motion_bank
from sensemaking.settings import load_config

HORIZONS_S = (0.2, 0.5, 1.0)
WARM = 3  # detections before a prediction is scored (a confirmed track's)


def _image_size(item: Item, data: Path) -> tuple[int, int]:
    if item.fmt == "kitti":
        info = read_kitti_seqinfo(data / "kitti" / "training" / "seqinfo.csv")[item.seq]
    else:
        info = read_seqinfo(data / "mot17" / item.seq / "seqinfo.ini")
    return info.width, info.height


def _objects(item: Item, gt: Detections) -> dict[int, dict[int, tuple[np.ndarray, bool]]]:
    """Object id -> frame -> (box, visible)."""
    assert gt.frame is not None and gt.tracker_id is not None and gt.class_id is not None
    if item.fmt == "kitti":
        keep = gt.class_id == class_id(item.cls)
        visible = gt.data["occluded"] <= 1
    else:
        keep = (gt.class_id == 1) & (gt.data["consider"] == 1)
        visible = gt.data["visibility"] >= 0.5
    out: dict[int, dict[int, tuple[np.ndarray, bool]]] = {}
    for i in np.flatnonzero(keep).tolist():
        out.setdefault(int(gt.tracker_id[i]), {})[int(gt.frame[i])] = (
            gt.xyxy[i],
            bool(visible[i]),
        )
    return out


def _detections(item: Item, data: Path, floor: float) -> dict[int, np.ndarray]:
    """Frame -> (K, 4) boxes of the sequence's detections of the class scoring >= ``floor``."""
    if item.fmt == "kitti":
        d = read_kitti_detections(item.det_path(data), item.cls)
        d = d[d.class_id == class_id(item.cls)]
    else:
        d = read_mot(item.det_path(data), kind="det")
    assert d.frame is not None and d.confidence is not None
    d = d[d.confidence >= floor]
    assert d.frame is not None
    return {int(f): d.xyxy[d.frame == f] for f in np.unique(d.frame).tolist()}


def _matched(boxes: np.ndarray | None, truth: np.ndarray) -> np.ndarray | None:
    if boxes is None or not len(boxes):
        return None
    scores = [_iou(b, truth) for b in boxes]
    best = int(np.argmax(scores))
    return boxes[best] if scores[best] >= 0.5 else None


def predictions(item: Item, data: Path, sets: list[str]) -> dict[str, list[float]]:
    """IoUs of the boxes predicted for one sequence: horizon name -> values."""
    fps = _fps(item, data)
    config = load_config(
        None, item.family, {"fps": fps, "image_size": _image_size(item, data)}, sets
    )
    kalman = config.kalman_config
    ahead = {f"{s:g}s": max(1, round(s * fps)) for s in HORIZONS_S}
    out: dict[str, list[float]] = {name: [] for name in (*ahead, "young")}
    dets = _detections(item, data, config.min_confidence)
    for track in _objects(item, _gt(item, data)).values():
        bank = motion_bank(kalman)
        seen = 0
        for f in range(min(track), max(track) + 1):
            truth, visible = track.get(f, (None, False))
            m = _matched(dets.get(f), truth) if truth is not None and visible else None
            if seen == 0:
                if m is not None:
                    bank.add(m[None])
                    seen = 1
                continue
            if m is not None and seen < WARM and truth is not None:
                out["young"].append(_iou(bank.peek(1)[0], truth))
            bank.predict(1)
            if m is None:
                continue
            bank.update(np.array([0]), m[None])
            seen += 1
            if seen < WARM:
                continue
            for name, k in ahead.items():
                later = track.get(f + k)
                if later is not None:
                    out[name].append(_iou(bank.peek(k)[0], later[0]))
    return out


def _cell(values: list[float]) -> str:
    if not values:
        return "      -     "
    v = np.asarray(values)
    return f"{v.mean():.3f}/{np.mean(v >= 0.3):.3f}"


def _rows(args: argparse.Namespace) -> Iterator[tuple[str, str, dict[str, list[float]]]]:
    for item in items(args.only, args.data):
        yield item.bench, item.seq, predictions(item, args.data, args.set)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=lambda p: Path(p), default=DATA)
    ap.add_argument("--only", action="append", choices=sorted(BENCHMARKS))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--per-sequence", action="store_true")
    args = ap.parse_args(argv)
    names = [f"{s:g}s" for s in HORIZONS_S] + ["young"]
    print(f"{'benchmark':28}{'sequence':22}" + "".join(f"{n:>13}" for n in names))
    pooled: dict[str, dict[str, list[float]]] = {}
    for bench, seq, got in _rows(args):
        into = pooled.setdefault(bench, {n: [] for n in names})
        for n in names:
            into[n] += got[n]
        if args.per_sequence:
            print(f"{bench:28}{seq:22}" + "".join(f"{_cell(got[n]):>13}" for n in names))
    for bench, got in pooled.items():
        print(f"{bench:28}{'all':22}" + "".join(f"{_cell(got[n]):>13}" for n in names))


if __name__ == "__main__":
    main()

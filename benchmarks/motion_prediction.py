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
from pathlib import Path

import numpy as np
from occlusion_errors import BENCHMARKS, DATA, Item, _dets, _gt, _gt_objects, _iou, _seqinfo, items

from sensemaking.detections import Detections
from sensemaking.motion import motion_bank
from sensemaking.settings import load_config

HORIZONS_S = (0.2, 0.5, 1.0)
WARM = 3  # detections before a prediction is scored (a confirmed track's)


def _visible(item: Item, gt: Detections) -> set[tuple[int, int]]:
    """(object id, frame) of the ground-truth boxes labelled visible (KITTI ``occluded <= 1``,
    MOT17 visibility >= 0.5)."""
    assert gt.frame is not None and gt.tracker_id is not None
    if item.fmt == "kitti":
        seen = gt.data["occluded"] <= 1
    else:
        seen = gt.data["visibility"] >= 0.5
    return set(zip(gt.tracker_id[seen].tolist(), gt.frame[seen].tolist(), strict=True))


def _matched(
    dets: list[tuple[np.ndarray, float]], truth: np.ndarray, floor: float
) -> np.ndarray | None:
    """The detection scoring >= ``floor`` that best overlaps ``truth``, if by IoU >= 0.5."""
    best, box = 0.0, None
    for b, c in dets:
        if c >= floor and (v := _iou(b, truth)) > best:
            best, box = v, b
    return box if best >= 0.5 else None


def predictions(item: Item, data: Path, sets: list[str]) -> dict[str, list[float]]:
    """IoUs of the boxes predicted for one sequence: horizon name -> values."""
    info = _seqinfo(item, data)
    facts = {"fps": info.fps, "image_size": (info.width, info.height)}
    config = load_config(None, item.family, facts, sets)
    kalman = config.kalman_config
    ahead = {f"{s:g}s": max(1, round(s * info.fps)) for s in HORIZONS_S}
    out: dict[str, list[float]] = {name: [] for name in (*ahead, "young")}
    dets = _dets(item, data)
    gt = _gt(item, data)
    visible = _visible(item, gt)
    for oid, track in _gt_objects(item, gt).items():
        bank = motion_bank(kalman)
        seen = 0
        for f in range(min(track), max(track) + 1):
            truth = track.get(f)
            m = (
                _matched(dets.get(f, []), truth, config.min_confidence)
                if truth is not None and (oid, f) in visible
                else None
            )
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
                    out[name].append(_iou(bank.peek(k)[0], later))
    return out


def _cell(values: list[float]) -> str:
    if not values:
        return "      -     "
    v = np.asarray(values)
    return f"{v.mean():.3f}/{np.mean(v >= 0.3):.3f}"


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
    for item in items(args.only, args.data):
        bench, seq, got = item.bench, item.seq, predictions(item, args.data, args.set)
        into = pooled.setdefault(bench, {n: [] for n in names})
        for n in names:
            into[n] += got[n]
        if args.per_sequence:
            print(f"{bench:28}{seq:22}" + "".join(f"{_cell(got[n]):>13}" for n in names))
    for bench, got in pooled.items():
        print(f"{bench:28}{'all':22}" + "".join(f"{_cell(got[n]):>13}" for n in names))


if __name__ == "__main__":
    main()

"""Why pedestrians are not tracked yet (issue 27, "start tracks earlier on pedestrians").

On the shared KITTI pedestrian sequences (0000-0010, RRC and PointRCNN detections), every
ground-truth pedestrian box is classified by whether a *usable* detection covers it (IoU >= 0.5
with the box, any score) and whether our output and SORT's (roboflow ``trackers``, its defaults,
``frame_rate`` from the sequence; the ``benchmark`` extra) have a track on it (IoU >= 0.5). A
usable detection that we do not track is put down to the preset's thresholds (the
pedestrian class's own where ``class_confidence`` sets them): below
``min_confidence`` (it can neither start nor continue a track), between ``min_confidence`` and
``start_confidence`` (it continues a track, never starts one), or strong enough to start one:
then *confirmation* when fewer than ``min_hits`` of the object's frames up to this one had a
starting-strength detection (a new track is reported from its ``min_hits``-th detection on), else
*other* (association, or a track reported only later).

    python benchmarks/occlusion_errors.py --only kitti-rrc-pedestrian \
        --only kitti-pointrcnn-pedestrian run OUT            # our tracks, the preset
    python benchmarks/pedestrian_starts.py OUT [--set KEY=VALUE ...]

``--set`` only changes the thresholds the reasons are read against (pass the ones ``run`` used).
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import numpy as np
from occlusion_errors import DATA, Item, _best_det, _dets, _gt, _gt_objects, _iou, _res

from sensemaking.benchmark.peers import PeerAdapter
from sensemaking.classes import class_id
from sensemaking.config import TrackerConfig, apply_settings
from sensemaking.detections import Detections
from sensemaking.io.kitti import read_kitti_detections
from sensemaking.settings import parse_overrides

BENCHES = ("kitti-rrc-pedestrian", "kitti-pointrcnn-pedestrian")
SEQS = tuple(f"{i:04d}" for i in range(11))


def _boxes_by_frame(d: Detections, cls: int) -> dict[int, list[np.ndarray]]:
    assert d.frame is not None and d.class_id is not None
    out: dict[int, list[np.ndarray]] = {}
    for i in np.flatnonzero(d.class_id == cls).tolist():
        out.setdefault(int(d.frame[i]), []).append(d.xyxy[i])
    return out


def _sort_tracks(item: Item, data: Path) -> dict[int, list[np.ndarray]]:
    """SORT at its defaults over the sequence's detections of the class: boxes per frame."""
    d = read_kitti_detections(item.det_path(data), item.cls)
    cls = class_id(item.cls)
    d = d[d.class_id == cls]
    peer = PeerAdapter("sort", frame_rate=10.0)
    assert d.frame is not None
    out: dict[int, list[np.ndarray]] = {}
    last = int(d.frame.max()) if len(d) else -1
    for f in range(last + 1):
        tracks, _ = peer.update(d[d.frame == f], f)
        if len(tracks):
            out[f] = list(tracks.xyxy)
    return out


def _on(boxes: dict[int, list[np.ndarray]], frame: int, box: np.ndarray) -> bool:
    return any(_iou(b, box) >= 0.5 for b in boxes.get(frame, []))


def classify(item: Item, out: Path, data: Path, config: TrackerConfig) -> Counter[str]:
    """Counts of the ground-truth boxes of one sequence by detection, our and SORT's tracks."""
    cls = class_id(item.cls)
    objs = _gt_objects(item, _gt(item, data))
    dets = _dets(item, data)
    ours = _boxes_by_frame(_res(item, out), cls)
    sort = _sort_tracks(item, data)
    # the class's own thresholds (class_confidence), else the global ones
    low, start = (float(np.max(g)) for g in config.class_gates(np.array([cls])))
    c: Counter[str] = Counter()
    for frames in objs.values():
        strong = 0  # frames of this object so far with a detection strong enough to start
        for f in sorted(frames):
            box = frames[f]
            v, conf = _best_det(dets.get(f, []), box)
            usable = v >= 0.5
            strong += usable and conf >= start
            c["boxes"] += 1
            if not usable:
                c["no usable detection"] += 1
                continue
            c["usable"] += 1
            we, they = _on(ours, f, box), _on(sort, f, box)
            c["usable, ours"] += we
            c["usable, SORT"] += they
            if we:
                continue
            if conf < low:
                why = "below min_confidence"
            elif conf < start:
                why = "continues, cannot start"
            elif strong < config.min_hits:
                why = "confirmation (min_hits)"
            else:
                why = "other"
            c[f"not ours: {why}"] += 1
            c[f"not ours, SORT has it: {why}"] += they
    return c


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path, help="a run of occlusion_errors.py (our tracks)")
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    config = apply_settings(TrackerConfig.for_dataset("kitti"), parse_overrides(args.set))
    for bench in BENCHES:
        total: Counter[str] = Counter()
        for seq in SEQS:
            total += classify(Item(bench, seq), args.out, args.data, config)
        print(f"{bench}:")
        for key in sorted(total, key=lambda k: (k.startswith("not ours"), k)):
            print(f"  {key:48s} {total[key]:6d}")


if __name__ == "__main__":
    main()

"""The horizon estimated from the scene against the one KITTI's 3D labels imply, per sequence.

Truth: the shared data holds no calibration files, so the projection is the KITTI camera model
(:meth:`~sensemaking.reasoning.egomotion.CameraModel.kitti`, P2 of the tracking sequences). A
labelled object's bottom centre ``(X, Y, Z)`` (camera frame, m) stands on the road; the
horizon row that puts it at its distance on a flat road under a camera ``height_m`` high is
``cy + focal * (Y - height_m) / Z``. A frame's true horizon is the median of that over its
labelled objects (car, van, truck, pedestrian, cyclist) 4-60 m ahead.

Estimate: our tracker on the benchmark's detections, its visible tracks' boxes through
:class:`~sensemaking.reasoning.egomotion.HorizonEstimator` (what ``track --warnings --pitch
scene`` uses). Also the distance the monitor gives each visible track matched to a label
(IoU >= 0.5, within 40 m), level and scene, against the label's near face (``Z - l / 2``: the
box bottom is the nearest road contact).

    nice -n 10 .venv/bin/python benchmarks/horizon_error.py [--only kitti-rrc-car]

Prints per sequence: frames with a truth, the mean absolute horizon error (px) of the level
camera and of the estimate, the estimate's mean signed error (px), the median pitch (deg), and
the median absolute relative distance error, level and scene.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from sensemaking.benchmark.datasets import default_data_root, iter_benchmarks
from sensemaking.benchmark.runner import ours_config
from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.geometry import iou as box_iou
from sensemaking.io.kitti import read_kitti_labels
from sensemaking.reasoning.egomotion import CameraModel, EgoMotionConfig, HorizonEstimator
from sensemaking.tracker import Tracker

#: labelled classes whose bottom stands on the road
ON_ROAD = frozenset(CLASS_IDS[n] for n in ("car", "van", "truck", "pedestrian", "cyclist"))


def true_horizons(labels: Detections, cam: CameraModel) -> dict[int, float]:
    """Frame -> the median horizon row (px) the labelled objects 4-60 m ahead imply."""
    assert labels.frame is not None and labels.class_id is not None
    loc = np.asarray(labels.data["location"], dtype=np.float64)
    by: dict[int, list[float]] = {}
    for f, c, (_, y, z) in zip(labels.frame.tolist(), labels.class_id.tolist(), loc, strict=True):
        if c in ON_ROAD and 4.0 < z < 60.0:
            by.setdefault(f, []).append(cam.horizon_px + cam.focal_px * (y - cam.height_m) / z)
    return {f: float(np.median(v)) for f, v in by.items()}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None)
    p.add_argument("--only", action="append", default=None, metavar="NAME")
    args = p.parse_args(argv)
    root = args.data or default_data_root()
    if not Path(root).is_dir():
        print(f"{root}: no benchmark data", file=sys.stderr)
        return 2
    cam = CameraModel.kitti()
    for bench in iter_benchmarks(root, args.only or ["kitti-rrc-car"]):
        if bench.spec.family != "kitti":
            continue
        print(f"\n{bench.name}")
        print(
            "| seq | frames | level MAE px | scene MAE px | scene bias px | pitch deg "
            "| dist err level | dist err scene |"
        )
        print("|---|---|---|---|---|---|---|---|")
        pooled: dict[str, list[float]] = {"l": [], "s": [], "dl": [], "ds": []}
        for seq in bench.sequences:
            size = (int(seq.info.width), int(seq.info.height))
            labels = read_kitti_labels(seq.gt_path)
            truth = true_horizons(labels, cam)
            config = ours_config(bench.spec.family, fps=float(seq.info.fps), image_size=size)
            tracker = Tracker(config)
            est = HorizonEstimator(cam, config.fps, EgoMotionConfig(horizon_from_scene=True), size)
            frames = dict(seq.detections.frames())
            lab_frames = dict(labels.frames())
            el, es, bias, pitch, dl, ds = [], [], [], [], [], []
            for f in seq.frame_numbers:
                vis = tracker.update(frames.get(f, Detections.empty()), frame=f).visible
                cls = [] if vis.class_id is None else vis.class_id.tolist()
                hor = est.update(f, vis.xyxy, cls)
                pitch.append(est.pitch_deg)
                if f in truth:
                    el.append(abs(cam.horizon_px - truth[f]))
                    es.append(abs(hor - truth[f]))
                    bias.append(hor - truth[f])
                lab = lab_frames.get(f)
                if lab is None or len(lab) == 0 or len(vis) == 0:
                    continue
                iou = box_iou(vis.xyxy, lab.xyxy)
                loc = np.asarray(lab.data["location"], dtype=np.float64)
                length = np.asarray(lab.data["dimensions"], dtype=np.float64)[:, 2]
                for i, j in enumerate(iou.argmax(axis=1).tolist()):
                    near = loc[j, 2] - length[j] / 2.0
                    bottom = vis.xyxy[i, 3]
                    if iou[i, j] < 0.5 or not 0 < loc[j, 2] < 40.0 or bottom >= size[1] - 1:
                        continue
                    for h, acc in ((cam.horizon_px, dl), (hor, ds)):
                        if bottom > h:
                            acc.append(cam.focal_px * cam.height_m / (bottom - h) / near - 1.0)
            pooled["l"] += el
            pooled["s"] += es
            pooled["dl"] += dl
            pooled["ds"] += ds
            print(
                f"| {seq.name} | {len(el)} | {np.mean(el):.1f} | {np.mean(es):.1f} | "
                f"{np.mean(bias):+.1f} | {np.median(pitch):+.2f} | "
                f"{np.median(np.abs(dl)):.3f} | {np.median(np.abs(ds)):.3f} |"
            )
            sys.stdout.flush()
        print(
            f"| all | {len(pooled['l'])} | {np.mean(pooled['l']):.1f} | "
            f"{np.mean(pooled['s']):.1f} | | | {np.median(np.abs(pooled['dl'])):.3f} | "
            f"{np.median(np.abs(pooled['ds'])):.3f} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

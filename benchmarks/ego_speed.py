"""The ego-speed estimate against the ground truth's 3D labels, per KITTI sequence.

Truth: KITTI 0000-0010 has no OXTS data here, but its labels give every annotated object's 3D
position in the camera frame. Between two frames 0.5 s apart, the objects that stand still
move together by the inverse of the camera's own motion: a 2D rigid transform (x, z) that maps
at least three labelled objects onto their later positions within 0.25 m (every pair tried,
RANSAC-style) is the camera's motion, its translation over the time the ego speed. Frames
where no three objects agree have no truth and are not scored.

Estimate: our tracker on the benchmark's detections, its visible tracks through
:class:`~sensemaking.reasoning.egomotion.WorldMotion` with the KITTI camera model (ground plane
from the box bottoms; ``--location`` also gives PointRCNN's 3D positions of the matched
detections, which the tracker's output does not carry yet).

    nice -n 10 .venv/bin/python benchmarks/ego_speed.py [--only kitti-rrc-car] [--location]

Prints per sequence: frames with truth, frames with an estimate among them, mean absolute and
median error (m/s), the share within 1 m/s, and the mean true speed.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from pathlib import Path

import numpy as np

from sensemaking.benchmark.datasets import default_data_root, iter_benchmarks
from sensemaking.benchmark.runner import ours_config
from sensemaking.detections import Detections
from sensemaking.io.kitti import read_kitti_labels
from sensemaking.reasoning.egomotion import CameraModel, WorldMotion
from sensemaking.tracker import Tracker

#: frames between the two positions of the truth (0.5 s at 10 fps)
SPAN = 5
#: an object agrees with a rigid motion when it lands within this many metres
INLIER_M = 0.25
#: objects that must agree
MIN_INLIERS = 3


def _rigid(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares 2D rotation R and translation t with q ~ p @ R.T + t (Kabsch)."""
    pc, qc = p.mean(0), q.mean(0)
    h = (p - pc).T @ (q - qc)
    u, _, vt = np.linalg.svd(h)
    r = vt.T @ u.T
    if np.linalg.det(r) < 0:
        vt[-1] *= -1
        r = vt.T @ u.T
    return r, qc - pc @ r.T


def true_speeds(labels: Detections, fps: float) -> dict[int, float]:
    """Frame -> ego speed (m/s) over the SPAN frames before it, from the static objects."""
    assert labels.frame is not None and labels.tracker_id is not None
    loc = labels.data["location"]
    by_frame: dict[int, dict[int, np.ndarray]] = {}
    for f, g, xyz in zip(labels.frame.tolist(), labels.tracker_id.tolist(), loc, strict=True):
        if g >= 0:
            by_frame.setdefault(f, {})[g] = np.array([xyz[0], xyz[2]])
    out: dict[int, float] = {}
    for f, now in by_frame.items():
        before = by_frame.get(f - SPAN)
        if before is None:
            continue
        common = sorted(set(now) & set(before))
        if len(common) < MIN_INLIERS:
            continue
        p = np.array([before[g] for g in common])
        q = np.array([now[g] for g in common])
        best: np.ndarray | None = None
        for i, j in itertools.combinations(range(len(common)), 2):
            r, t = _rigid(p[[i, j]], q[[i, j]])
            inl = np.linalg.norm(p @ r.T + t - q, axis=1) <= INLIER_M
            if best is None or inl.sum() > best.sum():
                best = inl
        if best is None or best.sum() < MIN_INLIERS:
            continue
        r, t = _rigid(p[best], q[best])
        # a static point maps as q = R p + t: the camera moved by -R^T t
        out[f] = float(np.linalg.norm(r.T @ t)) * fps / SPAN
    return out


def estimated_speeds(bench, seq, location: bool) -> dict[int, float]:
    size = (int(seq.info.width), int(seq.info.height))
    config = ours_config(bench.spec.family, fps=float(seq.info.fps), image_size=size)
    tracker = Tracker(config)
    world = WorldMotion(CameraModel.kitti(), config.fps, size)
    dets = seq.detections
    loc_of = {}
    if location and "location" in dets.data:
        loc_of = dict(zip(dets.source_row.tolist(), dets.data["location"].tolist(), strict=True))
    frames = dict(dets.frames())
    out: dict[int, float] = {}
    for f in seq.frame_numbers:
        result = tracker.update(frames.get(f, Detections.empty()), frame=f)
        vis = result.visible
        ids = [] if vis.tracker_id is None else vis.tracker_id.tolist()
        loc = None
        if loc_of:
            rows = vis.source_row.tolist() if vis.source_row is not None else []
            loc = np.array([loc_of.get(r, [math.nan] * 3) for r in rows]).reshape(-1, 3)
        ego, _ = world.update(f, ids, vis.xyxy, loc)
        if ego is not None:
            out[f] = ego.speed
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None)
    p.add_argument("--only", action="append", default=None, metavar="NAME")
    p.add_argument(
        "--location", action="store_true", help="use PointRCNN's 3D positions where given"
    )
    args = p.parse_args(argv)
    root = args.data or default_data_root()
    if not Path(root).is_dir():
        print(f"{root}: no benchmark data", file=sys.stderr)
        return 2
    only = args.only or ["kitti-rrc-car"]
    for bench in iter_benchmarks(root, only):
        if bench.spec.family != "kitti":
            continue
        print(f"\n{bench.name}{' (3D positions)' if args.location else ''}")
        print("| seq | truth frames | estimated | MAE m/s | median m/s | within 1 m/s | mean v |")
        print("|---|---|---|---|---|---|---|")
        all_err: list[float] = []
        for seq in bench.sequences:
            truth = true_speeds(read_kitti_labels(seq.gt_path), float(seq.info.fps))
            est = estimated_speeds(bench, seq, args.location)
            both = sorted(set(truth) & set(est))
            err = [abs(est[f] - truth[f]) for f in both]
            all_err += err
            mean_v = np.mean(list(truth.values())) if truth else math.nan
            if err:
                print(
                    f"| {seq.name} | {len(truth)} | {len(both)} | {np.mean(err):.2f} | "
                    f"{np.median(err):.2f} | {np.mean(np.array(err) <= 1.0):.0%} | {mean_v:.1f} |"
                )
            else:
                print(f"| {seq.name} | {len(truth)} | 0 | - | - | - | {mean_v:.1f} |")
            sys.stdout.flush()
        if all_err:
            a = np.array(all_err)
            print(
                f"| all | | {a.size} | {a.mean():.2f} | {np.median(a):.2f} | "
                f"{np.mean(a <= 1.0):.0%} | |"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

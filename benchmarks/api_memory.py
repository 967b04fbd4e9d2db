"""Memory of a long run through the Python API: the tracker alone, 100,000 frames.

A synthetic street (``--objects`` boxes crossing a 1242x375 image at different speeds, each
re-entering when it leaves, 5 % missed detections and a false positive now and then) is fed to
``Tracker.update`` frame by frame; the script prints the resident memory (VmRSS) and the
tracker's cache statistics at 10k frames and every 50k. Memory grows while the bounded caches
of clingo's answers fill, then stays flat: the tracker keeps live tracks only.

    python benchmarks/api_memory.py [--frames 100000] [--objects 12]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100_000)
    ap.add_argument("--objects", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    from sensemaking.detections import Detections
    from sensemaking.tracker import Tracker, TrackerConfig

    rng = np.random.default_rng(args.seed)
    n = args.objects
    width, height = 1242, 375
    speed = rng.uniform(-12, 12, n)  # pixels per frame
    speed[np.abs(speed) < 2] = 3.0
    size = rng.uniform(40, 120, n)
    lane_y = rng.uniform(120, 300, n)
    offset = rng.uniform(0, width + 200, n)
    tracker = Tracker(TrackerConfig.for_dataset("kitti", fps=10, image_size=(width, height)))
    marks = {10_000, args.frames} | set(range(50_000, args.frames + 1, 50_000))
    print(
        f"{'frames':>8} {'RSS MB':>8} {'ms/frame':>9} {'components':>11} {'cache hits':>11} "
        f"{'solver calls':>12}"
    )
    print(f"{0:8d} {rss_mb():8.1f}")
    t0 = time.perf_counter()
    for f in range(1, args.frames + 1):
        x = (offset + speed * f) % (width + 200) - 100
        boxes = np.stack([x, lane_y - size / 2, x + size, lane_y + size / 2], axis=1)
        keep = (rng.random(n) > 0.05) & (boxes[:, 2] > 0) & (boxes[:, 0] < width)
        boxes = np.clip(boxes[keep], 0, [width, height, width, height])
        if rng.random() < 0.05:  # a false positive
            fx, fy = rng.uniform(0, width - 50), rng.uniform(0, height - 50)
            boxes = np.vstack([boxes, [fx, fy, fx + 50, fy + 50]])
        boxes = boxes[(boxes[:, 2] - boxes[:, 0] > 2) & (boxes[:, 3] - boxes[:, 1] > 2)]
        dets = Detections(
            boxes, confidence=np.full(len(boxes), 0.95), class_id=np.full(len(boxes), 2)
        )
        tracker.update(dets, frame=f)
        if f in marks:
            s = tracker.solver.stats
            print(
                f"{f:8d} {rss_mb():8.1f} {(time.perf_counter() - t0) / f * 1e3:9.2f} "
                f"{s['components']:11d} "
                f"{s['cache_hits']:11d} {s['solver_calls']:12d}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

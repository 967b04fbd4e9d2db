"""Rendering speed against tracking speed, measured in one run on KITTI (no images: plain canvas).

Tracks KITTI car sequences (RRC detections in ``../shared/data/kitti``) until at least
``--frames`` frames (default 1000) are done, timing :meth:`Tracker.update`; then renders the same
frame results (with the situation monitor's warnings, computed beforehand and timed apart) as a
GIF, an mp4 and a folder of PNGs, and times the drawing alone. Prints ms/frame and the ratio
render time / track time for each; the budget is a ratio below 1 (drawing must not be slower than
tracking). ``--check`` exits with status 1 when the GIF or mp4 ratio is 1 or more.

    python benchmarks/render_speed.py [--data ../shared/data/kitti] [--frames 1000] [--check]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

DEFAULT_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "kitti"


def track_sequences(data: Path, min_frames: int) -> tuple[list, float]:
    """(runs, seconds spent in Tracker.update) for KITTI car sequences until ``min_frames``."""
    from sensemaking.detections import Detections
    from sensemaking.io.kitti import read_kitti_detections, read_kitti_seqinfo
    from sensemaking.tracker import Tracker, TrackerConfig
    from sensemaking.viz._run import Run

    infos = read_kitti_seqinfo(data / "training" / "seqinfo.csv")
    runs, seconds, total = [], 0.0, 0
    for name, info in sorted(infos.items()):
        det_path = data / "detections" / "rrc" / "car" / f"{name}.txt"
        if not det_path.exists():
            continue
        dets = read_kitti_detections(det_path, "car")
        by_frame = dict(dets.frames())
        tracker = Tracker(
            TrackerConfig.for_dataset("kitti", fps=info.fps, image_size=(info.width, info.height))
        )
        results = []
        t0 = time.perf_counter()
        for f in range(info.length):
            results.append(tracker.update(by_frame.get(f, Detections.empty()), frame=f))
        seconds += time.perf_counter() - t0
        runs.append(
            Run(results, width=info.width, height=info.height, fps=info.fps, name=f"KITTI {name}")
        )
        total += info.length
        if total >= min_frames:
            break
    return runs, seconds


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--data", type=Path, default=DEFAULT_DATA, help="KITTI folder (training/, detections/)"
    )
    ap.add_argument(
        "--frames", type=int, default=1000, help="track and render at least this many frames"
    )
    ap.add_argument(
        "--check", action="store_true", help="exit 1 when rendering is slower than tracking"
    )
    args = ap.parse_args(argv)
    if not (args.data / "training" / "seqinfo.csv").exists():
        print(f"render_speed: no KITTI data at {args.data}", file=sys.stderr)
        return 2

    from sensemaking.viz._run import monitor_warnings
    from sensemaking.viz.render import FrameDrawer, render_scene

    runs, track_s = track_sequences(args.data, args.frames)
    n = sum(len(r.frames) for r in runs)
    t0 = time.perf_counter()
    for run in runs:
        run.warnings = monitor_warnings(run)
    monitor_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    for run in runs:
        drawer = FrameDrawer(run)
        for f in run.frames:
            drawer.draw(f)
    draw_s = time.perf_counter() - t0
    size = FrameDrawer(runs[0]).size

    timings = {"draw only": draw_s}
    with tempfile.TemporaryDirectory(prefix="render-speed-") as tmp:
        for kind, suffix in (("gif", ".gif"), ("mp4", ".mp4"), ("png folder", "/")):
            t0 = time.perf_counter()
            for k, run in enumerate(runs):
                render_scene(run, f"{tmp}/run{k}{suffix}")
            timings[kind] = time.perf_counter() - t0

    def ms(s: float) -> str:
        return f"{1000 * s / n:7.3f}"

    print(
        f"{n} frames of {len(runs)} KITTI sequences (RRC car), "
        f"plain canvas {size[0]}x{size[1]} px, "
        f"{sum(len(r.warnings) for r in runs)} warnings"
    )
    print(f"{'':24} ms/frame   render/track")
    print(f"{'tracking':24} {ms(track_s)}")
    print(f"{'situation monitor':24} {ms(monitor_s)}   (not part of rendering; reported apart)")
    for kind, s in timings.items():
        print(f"{'render: ' + kind:24} {ms(s)}   {s / track_s:6.3f}")
    worst = max(timings["gif"], timings["mp4"]) / track_s
    print(
        f"budget render/track < 1 (gif and mp4): {'met' if worst < 1 else 'NOT met'} ({worst:.3f})"
    )
    return 1 if args.check and worst >= 1 else 0


if __name__ == "__main__":
    sys.exit(main())

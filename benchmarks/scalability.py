"""Per-frame time of the tracker against the number of tracks (the paper's scalability table).

Synthetic scenes (``sensemaking.synthetic.make_scene``) with N tracks, at least 30 % of them
overlapping another track in every frame, 100 frames each. For each N the abductive tracker and
the no-abduction ablation run in the same process, interleaved, so the ratio between them holds
even on a busy machine; absolute times drift with load.

    python benchmarks/scalability.py [--frames 100] [--seed 0] [--markdown docs/SCALABILITY.md]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from sensemaking.synthetic import make_scene, overlap_fraction
from sensemaking.tracker import Tracker, TrackerConfig

#: the paper's Figure 5 table: ms/frame for 5, 10, 20, 50, 100 tracks (i7-6850K, 3.6 GHz)
PAPER_MS = {5: 23.33, 10: 31.36, 20: 62.08, 50: 511.83, 100: 3996.38}
#: targets of the issue on this 2-core machine (median ms/frame)
TARGET_MS = {20: 10.0, 100: 10.0}


def time_run(scene, abduction: bool) -> tuple[list[float], list[float], Tracker]:
    """Per-frame wall and CPU milliseconds of ``Tracker.update`` over the scene."""
    tracker = Tracker(
        TrackerConfig(abduction=abduction, fps=scene.fps, image_size=(scene.width, scene.height))
    )
    wall, cpu = [], []
    for f, dets in scene.frames():
        w0, c0 = time.perf_counter(), time.process_time()
        tracker.update(dets, frame=f)
        wall.append((time.perf_counter() - w0) * 1000)
        cpu.append((time.process_time() - c0) * 1000)
    return wall, cpu, tracker


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--overlap",
        type=float,
        default=0.3,
        help="fraction of tracks overlapping another in every frame (at least)",
    )
    ap.add_argument("--tracks", default="5,10,20,50,100")
    ap.add_argument("--markdown", type=Path, default=None, help="also write the table as Markdown")
    args = ap.parse_args(argv)
    sizes = [int(n) for n in args.tracks.split(",")]
    rows = []
    header = (
        f"{'tracks':>6} {'overlap':>7} | {'paper ms':>9} | "
        f"{'ours ms (median)':>16} {'p95':>7} {'cpu':>6} "
        f"{'over budget':>11} | {'no-abd ms':>9} | {'ours/no-abd':>11} | {'paper/ours':>10}"
    )
    print(header)
    print("-" * len(header))
    for n in sizes:
        scene = make_scene(n, n_frames=args.frames, overlap=args.overlap, seed=args.seed)
        overlap = overlap_fraction(scene.ground_truth)
        # warm up (imports, first Control), then interleave the two modes
        time_run(make_scene(n, n_frames=5, overlap=args.overlap, seed=args.seed + 1), True)
        wall_a, cpu_a, trk = time_run(scene, True)
        wall_b, _, _ = time_run(scene, False)
        med_a, med_b = statistics.median(wall_a), statistics.median(wall_b)
        p95 = float(np.percentile(wall_a, 95))
        row = dict(
            tracks=n,
            overlap=overlap,
            paper=PAPER_MS.get(n),
            ours=med_a,
            p95=p95,
            cpu=statistics.median(cpu_a),
            timed_out=trk.stats["timed_out"],
            noabd=med_b,
        )
        rows.append(row)
        paper = f"{row['paper']:9.1f}" if row["paper"] else f"{'-':>9}"
        speedup = f"{row['paper'] / med_a:9.0f}x" if row["paper"] else f"{'-':>10}"
        print(
            f"{n:6d} {overlap:7.0%} | {paper} | {med_a:16.2f} {p95:7.2f} {row['cpu']:6.2f} "
            f"{row['timed_out']:11d} | "
            f"{med_b:9.2f} | {med_a / med_b:10.1f}x | {speedup}"
        )
    print()
    for n, target in TARGET_MS.items():
        got = next((r["ours"] for r in rows if r["tracks"] == n), None)
        if got is not None:
            print(
                f"target {n} tracks <= {target:.0f} ms/frame: "
                f"{'met' if got <= target else 'MISSED'} ({got:.2f} ms)"
            )
    print(
        f"machine: {platform.machine()}, "
        f"{platform.python_implementation()} {platform.python_version()}, "
        f"{__import__('os').cpu_count()} cores; "
        f"times are wall-clock medians over {args.frames} frames"
    )
    if args.markdown:
        lines = [
            "| tracks | overlap | paper ms/frame | ours ms/frame (median) | p95 "
            "| no-abduction ms/frame | ours / no-abduction |",
            "|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in rows:
            paper = f"{r['paper']:.1f}" if r["paper"] else "-"
            lines.append(
                f"| {r['tracks']} | {r['overlap']:.0%} | {paper} | {r['ours']:.2f} | "
                f"{r['p95']:.2f} | "
                f"{r['noabd']:.2f} | {r['ours'] / r['noabd']:.1f}x |"
            )
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

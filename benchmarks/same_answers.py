"""Dump our tracker's answers on every shared benchmark, and time it, to compare two versions.

For every sequence of every benchmark in ``../shared/data`` our tracker (the benchmark's
parameter set) writes one line per output track and frame (id, box, state, occluder,
visibility) and one line per event to ``OUT/<benchmark>/<sequence>.txt``. Two versions'
directories compare with ``diff -r``; ``--compare DIR`` does that and names the first
difference per sequence. It prints the mean and worst milliseconds per frame of
``Tracker.update`` per benchmark, in wall-clock time, in the calling thread's CPU time and in
the process's CPU time (on a loaded machine the wall clock counts the time other processes
ran; work a worker thread does beside the tracker is not in the thread's CPU figure, a wait for
it is in the wall-clock one; the process's figure counts every thread's work).

    python benchmarks/same_answers.py OUT [--data ../shared/data] [--only kitti-rrc-car ...]
        [--compare OTHER_OUT] [--gc-freeze]

``--gc-freeze`` times the frames as ``sensemaking track`` runs them: the collector stops walking
what exists once a sequence's tracker and frames are set up (``gc.freeze``), so a full
collection no longer walks the libraries' own objects (25-30 ms frames otherwise).
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path

import numpy as np


def _lines(result) -> list[str]:
    tracks = result.tracks
    out = []
    state = tracks.data.get("state", np.zeros(len(tracks), dtype=np.int64))
    occ = tracks.data.get("occluder", np.full(len(tracks), -1))
    vis = tracks.data.get("visibility", np.zeros(len(tracks), dtype=np.int64))
    for i in np.argsort(tracks.tracker_id, kind="stable").tolist():
        box = " ".join(f"{v:.2f}" for v in tracks.xyxy[i].tolist())
        out.append(
            f"{result.frame} T {int(tracks.tracker_id[i])} {box} {int(state[i])} "
            f"{int(occ[i])} {int(vis[i])}"
        )
    for ev in result.events:
        out.append(f"{result.frame} E {ev.name} {' '.join(map(str, ev.args))}")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--data", type=Path, default=None)
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--compare", type=Path, default=None)
    parser.add_argument("--gc-freeze", action="store_true", help="as sensemaking track does")
    args = parser.parse_args(argv)
    from sensemaking.benchmark.datasets import iter_benchmarks
    from sensemaking.detections import Detections
    from sensemaking.tracker import Tracker, TrackerConfig

    differ = 0
    for bench in iter_benchmarks(args.data, args.only):
        times: list[float] = []
        cpu: list[float] = []
        proc: list[float] = []
        for seq in bench.sequences:
            config = TrackerConfig.for_dataset(
                bench.spec.family,
                fps=float(seq.info.fps),
                image_size=(seq.info.width, seq.info.height),
            )
            tracker = Tracker(config)
            frames = dict(seq.detections.frames())
            lines: list[str] = []
            if args.gc_freeze:
                gc.freeze()
            for f in seq.frame_numbers:
                dets = frames.get(f, Detections.empty())
                t0, c0, p0 = time.perf_counter(), time.thread_time(), time.process_time()
                result = tracker.update(dets, frame=f)
                times.append(time.perf_counter() - t0)
                cpu.append(time.thread_time() - c0)
                proc.append(time.process_time() - p0)
                lines += _lines(result)
            if args.gc_freeze:
                gc.unfreeze()
            path = args.out / bench.name / f"{seq.name}.txt"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text("\n".join(lines) + "\n")
            if args.compare is not None:
                other = [
                    line
                    for line in (args.compare / bench.name / f"{seq.name}.txt")
                    .read_text()
                    .splitlines()
                    if line
                ]
                first = next(
                    (i for i, (a, b) in enumerate(zip(lines, other, strict=False)) if a != b), None
                )
                if first is None and len(lines) != len(other):
                    first = min(len(lines), len(other))
                if first is not None:
                    differ += 1
                    print(
                        f"  {bench.name}/{seq.name}: first difference at line {first + 1}: "
                        f"{lines[first] if first < len(lines) else '<end>'!r} vs "
                        f"{other[first] if first < len(other) else '<end>'!r}"
                    )
        ms, cpu_ms, proc_ms = (np.array(x) * 1000.0 for x in (times, cpu, proc))
        print(
            f"{bench.name:28s} frames {len(ms):6d}  mean {ms.mean():6.2f} ms  "
            f"p95 {np.percentile(ms, 95):6.2f} ms  worst {ms.max():7.2f} ms  "
            f"cpu mean {cpu_ms.mean():6.2f} ms  cpu p95 {np.percentile(cpu_ms, 95):6.2f} ms  "
            f"cpu worst {cpu_ms.max():7.2f} ms  proc mean {proc_ms.mean():6.2f} ms  "
            f"proc worst {proc_ms.max():7.2f} ms",
            flush=True,
        )
    if args.compare is not None:
        print(f"{differ} sequences differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())

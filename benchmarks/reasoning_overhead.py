"""Overhead of online reasoning on KITTI: tracker alone vs tracker + SituationMonitor.

Runs :class:`sensemaking.tracker.Tracker` on the KITTI car sequences (RRC detections in
``../shared/data/kitti``) per sequence without and with a
:class:`sensemaking.reasoning.online.SituationMonitor` (and a :class:`~sensemaking.scene.SceneRecorder`)
fed every frame result, and prints per-frame times and their ratio measured in this one run,
and whether the ratio is within the budget of at most 1.20 (reasoning adds at most 20 %). The two
conditions alternate sequence by sequence, in turn first and second; the fastest of ``--repeat``
runs of each counts, and the ratio of the whole runs is also printed repeat by repeat.
``--gt`` also times the monitor on the ground-truth tracks (all objects of every class, no
tracker needed).

    python benchmarks/reasoning_overhead.py [--data ../shared/data/kitti] [--seqs 0000 0001 ...]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

DEFAULT_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "kitti"
#: acceptance criterion of issue #4: (tracker + reasoning) / tracker per-frame time
BUDGET = 1.20


def _fail(msg: str) -> int:
    print(f"reasoning_overhead: {msg}", file=sys.stderr)
    return 2


def gt_results(labels_path: Path):
    """Frame results made from KITTI ground truth: every labelled object visible."""
    from sensemaking.detections import Detections
    from sensemaking.io.kitti import read_kitti_labels
    from sensemaking.results import FrameResult

    gt = read_kitti_labels(labels_path)
    gt = gt[gt.tracker_id >= 0]
    frames = dict(gt.frames())
    n = int(gt.frame.max()) + 1 if len(gt) else 0
    for f in range(n):
        d = frames.get(f, Detections.empty())
        k = len(d)
        yield FrameResult(f, d.with_(data={"state": np.zeros(k, np.int64), "occluder": np.full(k, -1),
                                           "visibility": np.zeros(k, np.int64), "hidden_frames": np.zeros(k, np.int64)}))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="KITTI folder (training/, detections/)")
    ap.add_argument("--seqs", nargs="*", default=None, help="sequence names (default: all with RRC car detections)")
    ap.add_argument("--gt", action="store_true", help="also time the monitor on ground-truth tracks")
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs per sequence and condition; the fastest counts (default 3)")
    args = ap.parse_args(argv)

    try:
        from sensemaking.tracker import Tracker, TrackerConfig
    except ImportError as exc:
        return _fail(f"sensemaking.tracker is not available yet ({exc}); the overhead ratio needs the tracker")
    try:
        from sensemaking.io.kitti import read_kitti_detections, read_kitti_seqinfo
    except ImportError as exc:
        return _fail(f"sensemaking.io.kitti is not available ({exc})")
    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.scene import SceneRecorder

    det_dir = args.data / "detections" / "rrc" / "car"
    if not det_dir.is_dir():
        return _fail(f"no RRC car detections in {det_dir}")
    info = read_kitti_seqinfo(args.data / "training" / "seqinfo.csv")
    seqs = args.seqs or sorted(p.stem for p in det_dir.glob("*.txt"))
    tot = {"frames": 0, "base": 0.0, "with": 0.0, "monitor": 0.0, "base_cpu": 0.0, "with_cpu": 0.0,
           "calls": 0, "warnings": 0}
    print(f"times per frame in ms, fastest of {max(1, args.repeat)} runs, wall clock (CPU time in parentheses: "
          "steadier on a busy machine; the monitor and recorder inside the loop: wall clock only, as reading "
          "the CPU clock is a system call, too costly to make twice a frame)")
    print(f"{'seq':>5} {'frames':>6} {'tracker':>14} {'tracker+reasoning':>18} {'monitor':>13} {'ratio':>12} "
          f"{'solver calls':>12} {'warnings':>8}")
    from sensemaking.detections import Detections

    clock, cpu = time.perf_counter, time.process_time
    paired = [[0.0, 0.0] for _ in range(max(1, args.repeat))]  # CPU s of each repeat: alone, with
    for seq in seqs:
        si = info[seq]
        size = (si.width, si.height)
        dets = read_kitti_detections(det_dir / f"{seq}.txt")
        by_frame = dict(dets.frames())
        frames = range(si.length)
        inputs = [by_frame.get(f, Detections.empty()) for f in frames]
        config = TrackerConfig.for_dataset("kitti", fps=si.fps, image_size=size)
        # warm-up (imports, encodings, caches) on the first frames
        warm = Tracker(config)
        mon = SituationMonitor(fps=si.fps, image_size=size)
        for f, d in list(zip(frames, inputs))[:5]:
            mon.update(warm.update(d, frame=f))

        def tracker_alone() -> tuple[float, float]:
            tracker = Tracker(config)
            t0, c0 = clock(), cpu()
            for f, d in zip(frames, inputs):
                tracker.update(d, frame=f)
            return clock() - t0, cpu() - c0

        def with_reasoning() -> tuple[float, float, float, SituationMonitor, int]:
            tracker = Tracker(config)
            mon = SituationMonitor(fps=si.fps, image_size=size)
            rec = SceneRecorder(fps=si.fps, image_size=size)
            n_warn = 0
            tm = 0.0
            t0, c0 = clock(), cpu()
            for f, d in zip(frames, inputs):
                r = tracker.update(d, frame=f)
                t1 = clock()  # perf_counter: process_time is a system call here (0.65 us vs 0.05 us a read)
                rec.add(r)
                n_warn += len(mon.update(r))
                tm += clock() - t1
            return clock() - t0, cpu() - c0, tm, mon, n_warn

        base = base_cpu = full = full_cpu = t_mon = float("inf")
        for k in range(max(1, args.repeat)):
            # the two conditions alternate, first one then the other (a slow spell or a drift
            # of the machine hits both alike); the fastest run of each counts
            for condition in ((0, 1) if k % 2 == 0 else (1, 0)):
                if condition == 0:
                    wall, cpu_s = tracker_alone()
                    base, base_cpu = min(base, wall), min(base_cpu, cpu_s)
                else:
                    wall, cpu_s, tm, mon, n_warn = with_reasoning()
                    full, full_cpu = min(full, wall), min(full_cpu, cpu_s)
                    t_mon = min(t_mon, tm)
                paired[k][condition] += cpu_s
        n = len(frames)
        print(f"{seq:>5} {n:>6} {1000 * base / n:>6.2f} ({1000 * base_cpu / n:>5.2f}) "
              f"{1000 * full / n:>9.2f} ({1000 * full_cpu / n:>5.2f}) {1000 * t_mon / n:>13.2f} "
              f"{full / base:>5.3f} ({full_cpu / max(base_cpu, 1e-9):>4.2f}) {int(mon.stats['solver_calls']):>12} "
              f"{n_warn:>8}")
        for k, v in (("frames", n), ("base", base), ("with", full), ("monitor", t_mon), ("base_cpu", base_cpu),
                     ("with_cpu", full_cpu), ("calls", int(mon.stats["solver_calls"])),
                     ("warnings", n_warn)):
            tot[k] += v
    n = max(tot["frames"], 1)
    ratio = tot["with"] / max(tot["base"], 1e-9)
    ratio_cpu = tot["with_cpu"] / max(tot["base_cpu"], 1e-9)
    print(f"{'all':>5} {tot['frames']:>6} {1000 * tot['base'] / n:>6.2f} ({1000 * tot['base_cpu'] / n:>5.2f}) "
          f"{1000 * tot['with'] / n:>9.2f} ({1000 * tot['with_cpu'] / n:>5.2f}) {1000 * tot['monitor'] / n:>13.2f} "
          f"{ratio:>5.3f} ({ratio_cpu:>4.2f}) {tot['calls']:>12} {tot['warnings']:>8}")
    print(f"ratio (tracker + reasoning) / tracker = {ratio:.3f} wall, {ratio_cpu:.3f} CPU: reasoning adds "
          f"{100 * (ratio - 1):+.1f} % wall, {100 * (ratio_cpu - 1):+.1f} % CPU; the monitor and "
          f"recorder alone take {100 * tot['monitor'] / max(tot['base'], 1e-9):.1f} % of the tracker's time (wall)")
    ratios = [w / max(b, 1e-9) for b, w in paired]
    print(f"whole runs over all sequences, repeat by repeat, with / without reasoning (CPU): "
          f"{', '.join(f'{r:.3f}' for r in ratios)}; median {statistics.median(ratios):.3f}")
    verdict = {True: "WITHIN", False: "OVER"}
    print(f"budget: ratio <= {BUDGET:.2f} (reasoning adds at most {100 * (BUDGET - 1):.0f} %): "
          f"{verdict[ratio_cpu <= BUDGET]} budget by CPU time ({ratio_cpu:.3f}), "
          f"{verdict[ratio <= BUDGET]} budget by wall clock ({ratio:.3f}); CPU time is the steadier on a busy machine")

    if args.gt:
        print("\nmonitor on ground-truth tracks (all classes):")
        gt_frames = gt_ms = 0.0
        calls = warns = 0
        for seq in seqs:
            si = info[seq]
            results = list(gt_results(args.data / "training" / "label_02" / f"{seq}.txt"))
            mon = SituationMonitor(fps=si.fps, image_size=(si.width, si.height))
            t0 = time.process_time()
            for r in results:
                warns += len(mon.update(r))
            gt_ms += (time.process_time() - t0) * 1000
            gt_frames += len(results)
            calls += int(mon.stats["solver_calls"])
        print(f"  {int(gt_frames)} frames, {gt_ms / max(gt_frames, 1):.3f} ms CPU/frame, solver on "
              f"{100 * calls / max(gt_frames, 1):.1f} % of frames, {warns} warnings")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Time of ``sensemaking track`` with a ROS 2 bag in and MCAP out, against text in and out, on
KITTI 0001 (RRC car detections in ``../shared/data/kitti``): the target of issue 25 is at most
1.2 (reading and writing add at most 20 %).

Writes a bag (MCAP storage, one Detection2DArray a frame and a CameraInfo) from the detection
file, then runs in this one process, alternately, ``--repeat`` times each: text in / text out
(the tracks file), text in / text out with ``--write-hidden --events`` (the same content as
the MCAP), bag in / text out, text in / MCAP out and bag in / MCAP out. Prints the median
wall-clock and CPU time of each and the ratio of bag-in / MCAP-out to text in / out, the median
of the ratios of runs made one after the other (pairs share the machine's load). Times are of
the ``track`` verb's run, after one warm-up run of each (the imports are not counted).

    python benchmarks/ros_io.py [--data ../shared/data/kitti] [--seq 0001] [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

DEFAULT_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "kitti"
#: target of issue 25: bag in / MCAP out over text in / out
TARGET = 1.2


def _fail(msg: str) -> int:
    print(f"ros_io: {msg}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="the KITTI folder")
    ap.add_argument("--seq", default="0001", help="sequence (default 0001)")
    ap.add_argument("--repeat", type=int, default=7, help="runs of each variant (default 7)")
    args = ap.parse_args(argv)
    det = args.data / "detections" / "rrc" / "car" / f"{args.seq}.txt"
    if not det.is_file():
        return _fail(f"{det} not found (../shared/data is absent?)")
    try:
        from sensemaking.ros.convert import write_detection_bag
    except ImportError as exc:
        return _fail(f"{exc} (pip install 'sensemaking[ros]')")
    from sensemaking.cli import main as cli
    from sensemaking.detections import Detections
    from sensemaking.io.kitti import read_kitti_seqinfo
    from sensemaking.io.stream import iter_detection_frames

    info = read_kitti_seqinfo(args.data / "training" / "seqinfo.csv")[args.seq]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        got = dict(iter_detection_frames(det, "kitti", "car"))
        bag = write_detection_bag(
            out / "bag",
            [(f, got.get(f, Detections.empty())) for f in range(info.length)],
            fps=info.fps,
            image_size=(info.width, info.height),
        )
        text = ["-q", "track", "--detections", str(det), "--format", "kitti"]
        from_bag = ["-q", "track", "--detections", str(bag), "--format", "kitti"]
        variants = {
            "text in, text out": [*text, "--output", str(out / "t.txt")],
            "text in, text out + hidden + events": [
                *text,
                "--output",
                str(out / "th.txt"),
                "--write-hidden",
                "--events",
                str(out / "th.jsonl"),
            ],
            "bag in, text out": [*from_bag, "--output", str(out / "b.txt")],
            "text in, MCAP out": [*text, "--output", str(out / "t.mcap")],
            "bag in, MCAP out": [*from_bag, "--output", str(out / "b.mcap")],
        }
        for argv_ in variants.values():  # warm-up: imports, caches
            if cli(argv_) != 0:
                return _fail(f"run failed: {' '.join(argv_)}")
        wall: dict[str, list[float]] = {k: [] for k in variants}
        cpu: dict[str, list[float]] = {k: [] for k in variants}
        for _ in range(max(1, args.repeat)):
            for name, argv_ in variants.items():
                w, c = time.perf_counter(), time.process_time()
                cli(argv_)
                wall[name].append(time.perf_counter() - w)
                cpu[name].append(time.process_time() - c)
    base = "text in, text out"
    print(f"KITTI {args.seq}, {info.length} frames, {args.repeat} runs each (median)")
    print(f"{'variant':38s} {'wall s':>8s} {'cpu s':>8s} {'ratio':>6s}")
    for name in variants:
        ratio = statistics.median(a / b for a, b in zip(cpu[name], cpu[base], strict=True))
        print(
            f"{name:38s} {statistics.median(wall[name]):8.3f} "
            f"{statistics.median(cpu[name]):8.3f} {ratio:6.2f}"
        )
    ratio = statistics.median(
        a / b for a, b in zip(cpu["bag in, MCAP out"], cpu[base], strict=True)
    )
    verdict = "met" if ratio <= TARGET else "NOT met"
    print(
        f"MCAP in/out over text in/out: {ratio:.2f} (CPU time, median of paired runs; "
        f"target <= {TARGET}: {verdict})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Peak memory of ``sensemaking track`` on a long input (issue 16: at most 200 MB on 100,000 frames
and 2.5 M detections with --events --warnings --scene).

Writes a synthetic MOTChallenge det.txt (``--objects`` boxes per frame moving across a 1920x1080
image, each living ``--life`` frames, with a little jitter), then runs ``sensemaking track`` on it
in this process and prints the peak resident memory (VmHWM) when the run has covered 10 %, 50 %
and 100 % of the frames, and the time per frame::

    nice -n 10 python benchmarks/streaming_memory.py --frames 100000 --objects 25

``--scene pipeline`` tracks the 25-object 30 fps scene of ``benchmarks/pipeline.py`` instead
(``--class car``, objects that stay in view for the whole input: issue 23), written by a child
process so that writing it does not count in the peak; ``--every N`` prints the resident memory
(VmRSS) and the peak every N frames::

    nice -n 10 python benchmarks/streaming_memory.py --scene pipeline --frames 100000 --every 10000

Linux only (reads /proc/self/status).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def write_detections(path: Path, frames: int, objects: int, life: int, seed: int = 0) -> int:
    """A det.txt of ``frames`` frames with ``objects`` boxes each; returns the number of lines."""
    rng = np.random.default_rng(seed)
    slot = np.arange(objects)
    y = 60.0 + slot * (900.0 / max(objects, 1))
    n = 0
    with path.open("w") as fh:
        for start in range(1, frames + 1, 1000):
            block = []
            for f in range(start, min(start + 1000, frames + 1)):
                age = (f + slot * (life // max(objects, 1))) % life  # staggered lives
                x = 20.0 + age * (1700.0 / life) + rng.normal(0, 1.0, objects)
                yy = y + rng.normal(0, 1.0, objects)
                score = 0.9 + 0.09 * rng.random(objects)
                block.extend(
                    f"{f},-1,{x[i]:.2f},{yy[i]:.2f},60.00,30.00,{score[i]:.3f},-1,-1,-1\n"
                    for i in range(objects)
                )
            fh.write("".join(block))
            n += len(block)
    return n


def peak_mb(field: str = "VmHWM") -> float:
    """``field`` of /proc/self/status (VmHWM: the peak resident memory; VmRSS: now), MB."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def write_pipeline_scene(folder: Path, frames: int) -> int:
    """The scene of ``benchmarks/pipeline.py`` (det.txt and seqinfo.ini in ``folder``), written
    by a child process; returns its number of detections."""
    here = Path(__file__).resolve().parent
    code = (
        f"import sys; sys.path.insert(0, {str(here)!r}); from pathlib import Path; "
        f"from pipeline import write_synthetic; write_synthetic(Path({str(folder)!r}), {frames})"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    with (folder / "det.txt").open() as fh:
        return sum(1 for _ in fh)


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--frames", type=int, default=100_000)
    ap.add_argument("--objects", type=int, default=25, help="boxes per frame")
    ap.add_argument("--life", type=int, default=400, help="frames an object stays in view")
    ap.add_argument(
        "--scene",
        choices=("crossing", "pipeline"),
        default="crossing",
        help="crossing: boxes crossing the image (--objects, --life); pipeline: the 25-object "
        "scene of benchmarks/pipeline.py, tracked as --class car",
    )
    ap.add_argument("--every", type=int, default=0, help="print VmRSS every N frames")
    args = ap.parse_args()

    from sensemaking.cli import _progress
    from sensemaking.cli import main as cli_main

    marks = sorted({max(1, args.frames // 10), max(1, args.frames // 2), args.frames})
    seen: list[tuple[int, float, float]] = []
    advance = _progress.Progress.advance
    t0 = [0.0]

    def watched(self: _progress.Progress, n: int = 1) -> None:
        before = self.done
        advance(self, n)
        while len(seen) < len(marks) and self.done >= marks[len(seen)]:
            seen.append((self.done, peak_mb(), time.perf_counter() - t0[0]))
        if args.every and self.done // args.every > before // args.every:
            print(
                f"frame {self.done:>7d}: RSS {peak_mb('VmRSS'):6.0f} MB, peak "
                f"{peak_mb():6.0f} MB ({time.perf_counter() - t0[0]:7.1f} s)",
                flush=True,
            )

    _progress.Progress.advance = watched  # type: ignore[method-assign]
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        if args.scene == "pipeline":
            det = root / "det.txt"
            lines = write_pipeline_scene(root, args.frames)
            classes = ["--class", "car"]
        else:
            (root / "SYN-01" / "det").mkdir(parents=True)
            det = root / "SYN-01" / "det" / "det.txt"
            lines = write_detections(det, args.frames, args.objects, args.life)
            (root / "SYN-01" / "seqinfo.ini").write_text(
                f"[Sequence]\nname=SYN-01\nframeRate=30\nseqLength={args.frames}\n"
                "imWidth=1920\nimHeight=1080\n"
            )
            classes = []
        size_mb = det.stat().st_size / 2**20
        before = peak_mb()
        print(
            f"input: {args.frames} frames, {lines} detections, {size_mb:.0f} MB; "
            f"peak before the run "
            f"{before:.0f} MB"
        )
        t0[0] = time.perf_counter()
        code = cli_main(
            [
                "-q",
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                *classes,
                "--output",
                str(root / "out.txt"),
                "--events",
                str(root / "ev.jsonl"),
                "--warnings",
                str(root / "w.jsonl"),
                "--scene",
                str(root / "scene.json"),
            ]
        )
        total = time.perf_counter() - t0[0]
        print(f"exit {code}; scene {(root / 'scene.json').stat().st_size / 2**20:.0f} MB")
    for done, mb, at in seen:
        print(
            f"after {done:>7d} frames: peak {mb:6.0f} MB  "
            f"({at:7.1f} s, {1000 * at / done:.2f} ms/frame)"
        )
    print(
        f"total {total:.1f} s, {1000 * total / args.frames:.2f} ms/frame; peak {peak_mb():.0f} MB"
    )


if __name__ == "__main__":
    main()

"""Time per frame of this checkout's tracker against another checkout's, in one run.

For each benchmark of ``../shared/data`` the two versions run ``same_answers.py`` on it in
turn (this one, the other, this one, the other, ...), each in a fresh process, so a slow spell
of a shared machine hits both alike; the script prints each version's median mean-ms-per-frame
over ``--repeat`` turns, their ratio, the worst frame, and whether their tracks and events are
identical. With ``--cpu`` the times are the tracker thread's CPU time (a loaded machine), with
``--process`` the process's (the tracker's worker threads included: work moved off the tracker's
thread still counts); ``--gc-freeze`` times the frames as ``sensemaking track`` runs them.

    git worktree add /tmp/old <commit>
    python benchmarks/compare_versions.py --other /tmp/old/src [--only kitti-rrc-car] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
LINE = re.compile(
    r"^(\S+)\s+frames\s+(\d+)\s+mean\s+([\d.]+) ms\s+p95\s+([\d.]+) ms\s+worst\s+([\d.]+) ms"
    r"(?:\s+cpu mean\s+([\d.]+) ms\s+cpu p95\s+([\d.]+) ms\s+cpu worst\s+([\d.]+) ms)?"
    r"(?:\s+proc mean\s+([\d.]+) ms\s+proc worst\s+([\d.]+) ms)?"
)
#: the mean and worst figures of LINE: wall clock, CPU time of the tracker's thread, CPU time of
#: the process (every thread's: the tracker's and its workers')
GROUPS = {"wall": (3, 5), "cpu": (6, 8), "process": (9, 10)}
BENCHMARKS = (
    "kitti-rrc-car",
    "kitti-rrc-pedestrian",
    "kitti-pointrcnn-car",
    "kitti-pointrcnn-pedestrian",
    "mot17-yolox-halfval",
    "mot17-frcnn",
    "mot15",
)


def _run(
    src: Path | None,
    bench: str,
    out: Path,
    compare: Path | None,
    clock: str = "wall",
    freeze: bool = False,
) -> tuple[float, float, bool]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src)
    cmd = [sys.executable, str(HERE / "same_answers.py"), str(out), "--only", bench]
    if compare is not None:
        cmd += ["--compare", str(compare)]
    if freeze:
        cmd.append("--gc-freeze")
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    match = next((m for m in map(LINE.match, proc.stdout.splitlines()) if m), None)
    if match is None:
        raise SystemExit(f"{bench}: no timing line from {' '.join(cmd)}\n{proc.stderr[-2000:]}")
    mean, worst = GROUPS[clock]
    if match.group(mean) is None:
        raise SystemExit(f"{bench}: no {clock} times from {' '.join(cmd)}")
    same = compare is None or proc.returncode == 0
    return float(match.group(mean)), float(match.group(worst)), same


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--other", type=Path, required=True, help="the other checkout's src/ folder")
    ap.add_argument("--only", nargs="*", default=list(BENCHMARKS))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cpu", action="store_true", help="the tracker thread's CPU time")
    ap.add_argument(
        "--process", action="store_true", help="the process's CPU time (the workers' too)"
    )
    ap.add_argument(
        "--gc-freeze", action="store_true", help="gc.freeze() per sequence, as the CLI does"
    )
    args = ap.parse_args(argv)
    clock = "process" if args.process else "cpu" if args.cpu else "wall"
    print(
        f"{'benchmark':28s} {'this ms':>8} {'other ms':>9} {'ratio':>6} {'worst this':>10} "
        f"{'worst other':>11} {'same answers':>12}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for bench in args.only:
            this, other, worst_this, worst_other, same = [], [], [], [], True
            for _r in range(args.repeat):
                o = _run(args.other, bench, Path(tmp) / "other", None, clock, args.gc_freeze)
                t = _run(
                    None, bench, Path(tmp) / "this", Path(tmp) / "other", clock, args.gc_freeze
                )
                other.append(o[0])
                worst_other.append(o[1])
                this.append(t[0])
                worst_this.append(t[1])
                same &= t[2]
            a, b = statistics.median(this), statistics.median(other)
            print(
                f"{bench:28s} {a:8.2f} {b:9.2f} {a / b:6.2f} {min(worst_this):10.1f} "
                f"{min(worst_other):11.1f} {'yes' if same else 'no':>12}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

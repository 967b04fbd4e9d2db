"""Byte-for-byte comparison of two checkouts' ``sensemaking track`` outputs on the shared data.

For every sequence of ``../shared/data`` (MOT17, MOT15, KITTI RRC car / pedestrian, KITTI
PointRCNN car / pedestrian / cyclist jointly) each checkout's CLI, in a fresh process, writes its
tracks, events, warnings and scene file to ``OUT/<side>/<run>/``; then every file of one side
is compared with the other's, byte for byte. A few runs repeat with ``--no-abduction``. Exit
status 0 when every file is identical, 1 otherwise (the differing files are named).

    git worktree add /tmp/base <commit>
    python benchmarks/same_outputs.py --before /tmp/base --after . --out /tmp/same [--jobs 2]
    python benchmarks/same_outputs.py ... --only mot15 kitti-rrc-car   # a subset of the runs

A side whose ``OUT/<side>`` exists already is not run again (``--rerun`` to force it), so the
"before" outputs can be written once and compared with each step of a change.
"""

from __future__ import annotations

import argparse
import filecmp
import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
DATA = HERE.parent.parent / "shared" / "data"
PROGRESS = re.compile(r"\d+/\d+ [\d.]+/s")


@dataclass(frozen=True)
class Run:
    """One ``sensemaking track`` call: its name (a folder) and its input arguments."""

    name: str
    group: str
    args: tuple[str, ...]


def _runs(data: Path) -> Iterator[Run]:
    """Every shared sequence as a run, in a fixed order."""
    for group in ("mot17", "mot15"):
        for seq in sorted((data / group).glob("*/det/det.txt")):
            name = seq.parent.parent.name
            yield Run(f"{group}-{name}", group, ("--format", "mot", "--detections", str(seq)))
    kitti = data / "kitti"
    seqinfo = kitti / "training" / "seqinfo.csv"
    for cls in ("car", "pedestrian"):
        for seq in sorted((kitti / "detections" / "rrc" / cls).glob("*.txt")):
            args = ("--format", "kitti", "--class", cls, "--seqinfo", str(seqinfo))
            yield Run(
                f"kitti-rrc-{cls}-{seq.stem}",
                f"kitti-rrc-{cls}",
                (*args, "--detections", str(seq)),
            )
    prcnn = kitti / "detections" / "pointrcnn"
    classes = ("car", "pedestrian", "cyclist")
    for seq in sorted((prcnn / "car").glob("*.txt")):
        files = [str(prcnn / c / seq.name) for c in classes if (prcnn / c / seq.name).exists()]
        yield Run(
            f"kitti-pointrcnn-{seq.stem}",
            "kitti-pointrcnn",
            ("--format", "kitti", "--seqinfo", str(seqinfo), "--detections", *files),
        )


def _ablations(runs: list[Run]) -> list[Run]:
    """The first run of each group again without abduction (the Hungarian strategy)."""
    first: dict[str, Run] = {}
    for run in runs:
        first.setdefault(run.group, run)
    return [
        Run(f"{r.name}-no-abduction", f"{r.group}-no-abduction", (*r.args, "--no-abduction"))
        for r in first.values()
    ]


def _track(checkout: Path, run: Run, out: Path) -> tuple[Run, float, str]:
    """Run one checkout's CLI on ``run``, outputs in ``out``; (run, seconds, error text)."""
    out.mkdir(parents=True, exist_ok=True)
    fmt = run.args[run.args.index("--format") + 1]
    output = out / ("tracks-{class}.txt" if fmt == "kitti" else "tracks.txt")
    cmd = [
        sys.executable,
        "-m",
        "sensemaking",
        "track",
        *run.args,
        "--output",
        str(output),
        "--events",
        str(out / "events.jsonl"),
        "--warnings",
        str(out / "warnings.jsonl"),
        "--scene",
        str(out / "scene.json"),
    ]
    env = {**os.environ, "PYTHONPATH": str(checkout / "src")}
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=checkout)
    seconds = time.perf_counter() - t0
    # the progress bar's rate depends on the machine: only the other lines compare
    stderr = [ln for ln in proc.stderr.splitlines() if not PROGRESS.search(ln)]
    (out / "exit-status.txt").write_text("\n".join([str(proc.returncode), *stderr]) + "\n")
    return run, seconds, "" if proc.returncode == 0 else proc.stderr.strip()[-500:]


def _side(checkout: Path, runs: list[Run], out: Path, jobs: int) -> None:
    """Every run of one checkout into ``out/<run>/`` (``jobs`` processes at a time)."""
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(_track, checkout, r, out / r.name) for r in runs]
        for fut in futures:
            run, seconds, error = fut.result()
            note = f"  exit {error.splitlines()[-1] if error else ''}" if error else ""
            print(f"  {checkout.name}: {run.name:40s} {seconds:7.1f} s{note}", flush=True)


def _compare(a: Path, b: Path) -> list[str]:
    """Relative paths of files that differ between the trees ``a`` and ``b`` (or exist in only
    one); the ``exit-status.txt`` files compare too (stderr text and status)."""
    names_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    names_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    differ = sorted(str(p) + " (only one side)" for p in names_a ^ names_b)
    for rel in sorted(names_a & names_b):
        if not filecmp.cmp(a / rel, b / rel, shallow=False):
            differ.append(str(rel))
    return differ


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="the first checkout (repo root)")
    ap.add_argument("--after", type=Path, required=True, help="the second checkout (repo root)")
    ap.add_argument("--out", type=Path, required=True, help="folder for both sides' outputs")
    ap.add_argument("--data", type=Path, default=DATA, help="the shared benchmark data")
    ap.add_argument("--only", nargs="*", default=None, help="run groups (e.g. mot15) or names")
    ap.add_argument("--jobs", type=int, default=1, help="processes at a time per side")
    ap.add_argument("--rerun", action="store_true", help="run both sides even if written")
    ap.add_argument("--side", choices=("before", "after"), help="write only this side's outputs")
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        print(f"{args.data}: no benchmark data", file=sys.stderr)
        return 2
    runs = list(_runs(args.data))
    runs += _ablations(runs)
    if args.only:
        runs = [r for r in runs if r.group in args.only or r.name in args.only]
    print(f"{len(runs)} runs", flush=True)
    for side, checkout in (("before", args.before), ("after", args.after)):
        if args.side not in (None, side):
            continue
        out = args.out / side
        if out.exists() and not args.rerun:
            print(f"{side}: {out} exists, not run again", flush=True)
            continue
        _side(checkout.resolve(), runs, out, args.jobs)
    if args.side is not None:
        return 0
    differ = _compare(args.out / "before", args.out / "after")
    files = sum(1 for p in (args.out / "before").rglob("*") if p.is_file())
    for rel in differ:
        print(f"differs: {rel}")
    print(f"{len(runs)} runs, {files} files: {len(differ)} differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())

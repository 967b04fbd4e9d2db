"""What each output of ``sensemaking track`` costs, as a user runs it, in one run (issue 23).

Runs ``sensemaking track`` in this process on each input with no output but the tracks, then
with ``--events``, ``--warnings``, ``--scene`` and all three, and prints the wall-clock time of
each run as a ratio to the plain ``track`` run of the same input (the machine may be shared and
noisy: compare ratios within one run). From the run with every output it prints milliseconds
per frame (median, 95th and 99th percentile, worst) of the tracker (``Tracker.update``), of the
situation monitor (``SituationMonitor.update``) and of the whole pipeline step (tracker,
monitor, scene recorder and writers), and the monitor's time as a ratio to the tracker's.

Inputs: KITTI RRC car 0001 (``../shared/data/kitti``) and a synthetic 25-object scene at
30 fps, 1920x1080 (:func:`sensemaking.synthetic.make_scene`, written as a MOTChallenge
``det.txt`` with its ``seqinfo.ini`` and tracked as ``--class car``, so that near pairs of
vehicles reach the situation rules).

    python benchmarks/pipeline.py [--data ../shared/data] [--frames 900] [--profile driving]
        [--only kitti|synthetic] [--keep DIR] [--reference]

``--reference`` times the situation monitor's reference mode (a fresh clingo Control per
frame, the way before stream reasoning) instead of its long-lived one.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

_ROOT = Path(__file__).resolve().parents[1]
#: ../shared/data from the repository root (a worktree may sit one level deeper)
_DATA_CANDIDATES = (_ROOT.parent / "shared" / "data", _ROOT.parent.parent / "shared" / "data")
KITTI_SEQ = "0001"
#: the runs of each input: name and the outputs it adds to the tracks
RUNS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("track", ()),
    ("--events", ("events",)),
    ("--warnings", ("warnings",)),
    ("--scene", ("scene",)),
    ("all", ("events", "warnings", "scene")),
)


def _fail(msg: str) -> int:
    print(f"pipeline: {msg}", file=sys.stderr)
    return 2


def write_synthetic(folder: Path, n_frames: int, n_objects: int = 25, seed: int = 0) -> Path:
    """A ``n_objects``-object scene at 30 fps, 1920x1080, as ``folder/det.txt`` (MOT det format,
    frames from 1) and ``folder/seqinfo.ini``; returns the det file."""
    from sensemaking.synthetic import make_scene

    scene = make_scene(
        n_objects,
        n_frames=n_frames,
        overlap=0.4,
        width=1920,
        height=1080,
        fps=30.0,
        miss_rate=0.02,
        false_positive_rate=0.02,
        noise_px=1.5,
        seed=seed,
    )
    det = scene.detections
    assert det.frame is not None and det.confidence is not None
    order = np.argsort(det.frame, kind="stable")
    xyxy = det.xyxy[order]
    lines = [
        f"{f + 1},-1,{x1:.2f},{y1:.2f},{x2 - x1:.2f},{y2 - y1:.2f},{c:.4f}\n"
        for f, (x1, y1, x2, y2), c in zip(
            det.frame[order].tolist(), xyxy.tolist(), det.confidence[order].tolist(), strict=True
        )
    ]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "det.txt").write_text("".join(lines), encoding="utf-8")
    (folder / "seqinfo.ini").write_text(
        "[Sequence]\nname=synthetic25\nimWidth=1920\nimHeight=1080\nframeRate=30\n"
        f"seqLength={n_frames}\n",
        encoding="utf-8",
    )
    return folder / "det.txt"


class _Timer:
    """Wraps a method of a class for the duration of a ``with``: keeps each call's ms."""

    def __init__(self, cls: type, name: str) -> None:
        self.cls, self.name, self.ms = cls, name, []  # type: ignore[var-annotated]
        self._orig: Callable[..., Any] = getattr(cls, name)

    def __enter__(self) -> _Timer:
        orig, ms = self._orig, self.ms

        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return orig(*args, **kwargs)
            finally:
                ms.append((time.perf_counter() - t0) * 1000.0)

        setattr(self.cls, self.name, timed)
        return self

    def __exit__(self, *exc: object) -> None:
        setattr(self.cls, self.name, self._orig)


@contextlib.contextmanager
def _reference_monitor(on: bool) -> Iterator[None]:
    """SituationMonitor built with ``stream=False`` (a fresh Control per frame) when ``on``."""
    from sensemaking.reasoning import online

    if not on:
        yield
        return
    cls = online.SituationMonitor
    init = cls.__init__

    def fresh(self: Any, *args: Any, **kwargs: Any) -> None:
        init(self, *args, **{**kwargs, "stream": False})

    cls.__init__ = fresh  # type: ignore[method-assign]
    try:
        yield
    finally:
        cls.__init__ = init  # type: ignore[method-assign]


def run_track(argv: list[str], out: Path, outputs: tuple[str, ...], reference: bool) -> dict:
    """One ``sensemaking track`` run in this process; its wall time and per-call times."""
    from sensemaking.cli import main
    from sensemaking.pipeline import Pipeline
    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.tracker import Tracker

    args = [*argv, "--output", str(out / "tracks.txt")]
    for o in outputs:
        args += [f"--{o}", str(out / f"{o}.{'json' if o == 'scene' else 'jsonl'}")]
    tracker = _Timer(Tracker, "update")
    monitor = _Timer(SituationMonitor, "update")
    step = _Timer(Pipeline, "advance")  # what `track` calls once per input frame
    quiet = io.StringIO()
    with tracker, monitor, step, _reference_monitor(reference), contextlib.redirect_stdout(quiet):
        t0 = time.perf_counter()
        code = main(["--quiet", "track", *args])
        wall = time.perf_counter() - t0
    if code != 0:
        raise RuntimeError(f"sensemaking track {' '.join(args)} exited with {code}")
    return {"wall": wall, "tracker": tracker.ms, "monitor": monitor.ms, "step": step.ms}


def _stats(ms: list[float]) -> str:
    if not ms:
        return f"{'-':>7} {'-':>7} {'-':>7} {'-':>7}"
    a = np.asarray(ms)
    p95, p99 = np.percentile(a, [95, 99])
    return f"{statistics.median(ms):7.2f} {p95:7.2f} {p99:7.2f} {a.max():7.2f}"


def bench(name: str, argv: list[str], folder: Path, reference: bool) -> None:
    """Print the runs of one input."""
    print(f"\n{name}: sensemaking track {' '.join(argv)}")
    print(f"{'run':<11} {'wall s':>7} {'ratio':>6} {'frames':>6} {'ms/frame':>9}")
    base = None
    last: dict = {}
    warm = folder / name / "warm-up"
    warm.mkdir(parents=True, exist_ok=True)
    run_track(argv, warm, ("warnings",), reference)  # imports, caches: not part of a ratio
    for run, outputs in RUNS:
        out = folder / name / run.strip("-")
        out.mkdir(parents=True, exist_ok=True)
        r = run_track(argv, out, outputs, reference)
        frames = max(len(r["step"]), 1)
        base = base or r["wall"]
        print(
            f"{run:<11} {r['wall']:7.2f} {r['wall'] / base:6.2f} {len(r['step']):6d} "
            f"{1000 * r['wall'] / frames:9.2f}"
        )
        last = r
    print(f"\nwith every output, ms per frame: {'median':>7} {'p95':>7} {'p99':>7} {'worst':>7}")
    for part in ("tracker", "monitor", "step"):
        label = {"step": "whole pipeline step"}.get(part, part)
        print(f"  {label:<29}  {_stats(last[part])}")
    t, m = sum(last["tracker"]), sum(last["monitor"])
    if t > 0:
        print(f"  monitor / tracker (total time): {m / t:.2f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=None, help="the shared data folder")
    ap.add_argument("--frames", type=int, default=900, help="frames of the synthetic scene")
    ap.add_argument("--profile", choices=("driving", "fixed"), default=None)
    ap.add_argument("--only", choices=("kitti", "synthetic"), default=None)
    ap.add_argument("--keep", type=Path, default=None, help="keep the outputs in this folder")
    ap.add_argument("--reference", action="store_true", help="fresh Control per frame")
    a = ap.parse_args(argv)
    data = a.data or next((d for d in _DATA_CANDIDATES if d.is_dir()), _DATA_CANDIDATES[0])
    profile = ["--profile", a.profile] if a.profile else []
    with tempfile.TemporaryDirectory() as tmp:
        folder = a.keep or Path(tmp)
        if a.only in (None, "kitti"):
            det = data / "kitti" / "detections" / "rrc" / "car" / f"{KITTI_SEQ}.txt"
            if not det.is_file():
                return _fail(f"no KITTI RRC detections at {det}")
            argv_k = ["--detections", str(det), "--format", "kitti", *profile]
            bench(f"kitti-rrc-car-{KITTI_SEQ}", argv_k, folder, a.reference)
        if a.only in (None, "synthetic"):
            det = write_synthetic(folder / "synthetic25", a.frames)
            argv_s = ["--detections", str(det), "--format", "mot", "--class", "car", *profile]
            bench(f"synthetic25-{a.frames}f", argv_s, folder, a.reference)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What a restart of the situation monitor's Control costs, fed ahead or at once (issue 23).

The monitor's stream solver replaces its clingo Control every ``STREAM_RESTART_FRAMES``
answers. Given the whole window at the restart frame (``STREAM_STAGE_FRAMES`` 0), that one
frame builds and grounds every frame of the window; fed ahead (the default), the next Control
gets a share of the window on each of the answers before. This records the monitor's input
(the tracker's frame results) of one ``sensemaking track --warnings`` run per input, then
replays it on one monitor per setting in the same process, frame by frame in turn (so both see
the same load), and prints the thread CPU time per frame of each: total as a ratio to the
first setting, median, 95th and 99th percentile, worst.

    python benchmarks/monitor_restarts.py [--data ../shared/data] [--frames 600]
        [--stages 0,4,10] [--repeat 2] [--only kitti|synthetic]

Inputs as ``benchmarks/pipeline.py``'s: KITTI RRC car 0001 (camera model, profile driving)
and the 25-object 30 fps scene (MOT format, profile fixed).
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pipeline import _DATA_CANDIDATES, KITTI_SEQ, write_synthetic  # noqa: E402


def record(argv: list[str], out: Path) -> tuple[dict[str, Any], list[Any]]:
    """The monitor's constructor arguments and every frame result of one ``track --warnings``
    run."""
    from sensemaking.cli import main
    from sensemaking.reasoning.online import SituationMonitor

    results: list[Any] = []
    kwargs: dict[str, Any] = {}
    init, update = SituationMonitor.__init__, SituationMonitor.update

    def keep_init(self: Any, *args: Any, **kw: Any) -> None:
        kwargs.update(kw, _args=args)
        init(self, *args, **kw)

    def keep_update(self: Any, result: Any) -> Any:
        results.append(result)
        return update(self, result)

    SituationMonitor.__init__ = keep_init  # type: ignore[method-assign]
    SituationMonitor.update = keep_update  # type: ignore[method-assign]
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            args = [*argv, "--output", str(out / "t.txt"), "--warnings", str(out / "w.jsonl")]
            code = main(["--quiet", "track", *args])
    finally:
        SituationMonitor.__init__ = init  # type: ignore[method-assign]
        SituationMonitor.update = update  # type: ignore[method-assign]
    if code != 0:
        raise RuntimeError(f"sensemaking track exited with {code}")
    return kwargs, results


def replay(kwargs: dict[str, Any], results: list[Any], stages: list[int], repeat: int) -> None:
    """One monitor per stage setting, each frame given to all in turn; prints their times."""
    from sensemaking.reasoning import online

    kw = dict(kwargs)
    args = kw.pop("_args")
    monitors = {s: online.SituationMonitor(*args, **kw) for s in stages}
    default = online.STREAM_STAGE_FRAMES
    gc.collect()
    gc.freeze()  # as `track` does once set up: the collections skip what was made before
    print(
        f"{'stage':>5} {'total ms':>9} {'ratio':>6} {'median':>7} {'p95':>7} {'p99':>7} "
        f"{'worst':>7} {'restarts':>8}"
    )
    try:
        for _ in range(repeat):
            ms: dict[int, list[float]] = {s: [] for s in stages}
            for m in monitors.values():
                m.reset()
            for i, r in enumerate(results):
                for s in stages if i % 2 else stages[::-1]:
                    online.STREAM_STAGE_FRAMES = s
                    t0 = time.thread_time()
                    monitors[s].update(r)
                    ms[s].append((time.thread_time() - t0) * 1000.0)
            first = sum(ms[stages[0]])
            for s in stages:
                a = np.asarray(ms[s])
                p95, p99 = np.percentile(a, [95, 99])
                solver = monitors[s]._stream
                restarts = solver.restarts if solver is not None else 0
                print(
                    f"{s:5d} {a.sum():9.0f} {a.sum() / first:6.2f} {statistics.median(ms[s]):7.2f}"
                    f" {p95:7.2f} {p99:7.2f} {a.max():7.2f} {restarts:8d}"
                )
    finally:
        online.STREAM_STAGE_FRAMES = default
        gc.unfreeze()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=None, help="the shared data folder")
    ap.add_argument("--frames", type=int, default=600, help="frames of the synthetic scene")
    ap.add_argument("--stages", default="0,4,10", help="STREAM_STAGE_FRAMES values to compare")
    ap.add_argument("--repeat", type=int, default=2, help="replays of each input")
    ap.add_argument("--only", choices=("kitti", "synthetic"), default=None)
    a = ap.parse_args(argv)
    try:
        stages = [int(x) for x in a.stages.split(",")]
    except ValueError:
        print(
            f"monitor_restarts: --stages {a.stages!r}: integers, comma-separated", file=sys.stderr
        )
        return 2
    data = a.data or next((d for d in _DATA_CANDIDATES if d.is_dir()), _DATA_CANDIDATES[0])
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        inputs: list[tuple[str, list[str]]] = []
        if a.only in (None, "kitti"):
            det = data / "kitti" / "detections" / "rrc" / "car" / f"{KITTI_SEQ}.txt"
            if not det.is_file():
                print(f"monitor_restarts: no KITTI RRC detections at {det}", file=sys.stderr)
                return 2
            inputs.append(
                (f"kitti-rrc-car-{KITTI_SEQ}", ["--detections", str(det), "--format", "kitti"])
            )
        if a.only in (None, "synthetic"):
            det = write_synthetic(folder / "synthetic25", a.frames)
            inputs.append(
                (
                    f"synthetic25-{a.frames}f",
                    ["--detections", str(det), "--format", "mot", "--class", "car"],
                )
            )
        for name, args in inputs:
            kwargs, results = record(args, folder)
            print(f"\n{name}: {len(results)} frames, monitor thread CPU ms per frame")
            replay(kwargs, results, stages, a.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())

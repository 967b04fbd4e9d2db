"""What the fixed-lag look-ahead costs per frame against the online tracker (issue 27).

Tracks each input with the family preset twice in this process -- online (``lookahead_s`` 0)
and with the look-ahead -- each on a solver cache of its own, alternating the two per input so
that both see the same machine load, and prints milliseconds per frame (mean and worst frame)
of each and their ratio, with the look-ahead's counters (frames contested, hypotheses rolled
forward, frames switched, contested frames decided online for want of work budget). The
machine may be shared and noisy: compare the ratios of one run.

Inputs (``../shared/data``): KITTI RRC car 0000-0010 and MOT17 YOLOX half-val 02, 04, 05, 09.

    python benchmarks/lookahead_cost.py [--data DIR] [--lookahead 0.2] [--only kitti|mot]
        [--seq NAME] [--set KEY=VALUE ...]

``--set`` gives the look-ahead run other settings too, as ``sensemaking track --set`` does
(e.g. ``lookahead_crowd_budget=true``, ``lookahead_continuity=300``); ``--seq`` keeps the
inputs whose name contains NAME.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

_ROOT = Path(__file__).resolve().parents[1]
_DATA_CANDIDATES = (_ROOT.parent / "shared" / "data", _ROOT.parent.parent / "shared" / "data")
KITTI_SEQS = tuple(f"{i:04d}" for i in range(11))
MOT_SEQS = (
    "MOT17-02-YOLOX-half",
    "MOT17-04-YOLOX-half",
    "MOT17-05-YOLOX-half",
    "MOT17-09-YOLOX-half",
)


def inputs(data: Path, only: str | None) -> list[tuple[str, str, Path, dict[str, Any]]]:
    """``(family, name, detections file, facts)`` of every input found."""
    from sensemaking.io.kitti import read_kitti_seqinfo
    from sensemaking.io.mot import read_seqinfo

    out: list[tuple[str, str, Path, dict[str, Any]]] = []
    if only in (None, "kitti"):
        info = read_kitti_seqinfo(data / "kitti" / "training" / "seqinfo.csv")
        for seq in KITTI_SEQS:
            path = data / "kitti" / "detections" / "rrc" / "car" / f"{seq}.txt"
            i = info[seq]
            facts = {"fps": i.fps, "image_size": (i.width, i.height)}
            out.append(("kitti", f"kitti-rrc-car {seq}", path, facts))
    if only in (None, "mot"):
        for seq in MOT_SEQS:
            i = read_seqinfo(data / "mot17" / seq)
            facts = {"fps": i.fps, "image_size": (i.width, i.height)}
            out.append(("mot", seq, data / "mot17" / seq / "det" / "det.txt", facts))
    return out


def timed(
    family: str,
    path: Path,
    facts: dict[str, Any],
    lookahead: float,
    sets: Sequence[str] = (),
) -> tuple[int, float, float, dict[str, Any]]:
    """``(frames, total ms, worst frame ms, look-ahead counters)`` of one run."""
    from sensemaking import settings
    from sensemaking.abduction.components import SolverCache
    from sensemaking.io.stream import iter_detection_frames
    from sensemaking.lookahead import LookaheadTracker
    from sensemaking.tracker import Tracker

    config = settings.load_config(None, family, {**facts, "lookahead_s": lookahead}, sets)
    cls = "car" if family == "kitti" else None
    frames = list(iter_detection_frames(path, family, cls))
    online = Tracker(config, solver_cache=SolverCache())
    delayed = LookaheadTracker(online) if config.lookahead_frames > 0 else None
    worst = total = 0.0
    for f, dets in frames:
        t0 = time.perf_counter()
        if delayed is None:
            online.update(dets, f)
        else:
            delayed.push(dets, f)
        ms = (time.perf_counter() - t0) * 1e3
        worst, total = max(worst, ms), total + ms
    if delayed is not None:
        t0 = time.perf_counter()
        delayed.flush()
        ms = (time.perf_counter() - t0) * 1e3
        total += ms
    return len(frames), total, worst, {} if delayed is None else dict(delayed.stats)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--lookahead", type=float, default=0.2, help="seconds (lookahead_s)")
    ap.add_argument("--only", choices=("kitti", "mot"), default=None)
    ap.add_argument("--seq", default=None, help="only the inputs whose name contains this")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    from sensemaking.errors import InputError

    data = args.data or next((p for p in _DATA_CANDIDATES if p.is_dir()), None)
    if data is None or not data.is_dir():
        print("lookahead_cost: no ../shared/data", file=sys.stderr)
        return 2
    pooled: dict[str, list[float]] = {}
    print(f"look-ahead {args.lookahead} s against online, ms per frame (mean, worst frame)")
    print(f"{'input':<28} {'online':>14} {'look-ahead':>14} {'ratio':>6}  counters")
    for family, name, path, facts in inputs(data, args.only):
        if not path.is_file() or (args.seq and args.seq not in name):
            continue
        try:
            n, on_ms, on_worst, _ = timed(family, path, facts, 0.0)
            _, la_ms, la_worst, stats = timed(family, path, facts, args.lookahead, args.set)
        except InputError as exc:
            print(f"lookahead_cost: {exc}", file=sys.stderr)
            return 2
        p = pooled.setdefault(family, [0.0, 0.0, 0.0])
        p[0] += n
        p[1] += on_ms
        p[2] += la_ms
        counters = ", ".join(
            f"{k} {stats[k]}"
            for k in ("contested", "rollouts", "switched", "by_continuity", "over_budget")
            if k in stats
        )
        print(
            f"{name:<28} {on_ms / n:6.2f} {on_worst:7.1f} {la_ms / n:6.2f} {la_worst:7.1f} "
            f"{la_ms / on_ms:6.2f}  {counters}"
        )
    for family, (n, on_ms, la_ms) in pooled.items():
        print(
            f"{family + ' (all frames)':<28} {on_ms / n:6.2f} {'':7} {la_ms / n:6.2f} {'':7} "
            f"{la_ms / on_ms:6.2f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

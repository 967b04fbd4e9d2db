"""Explanation quality on every shared benchmark: are the tracker's events and warnings true?

Runs our tracker (``TrackerConfig.for_dataset`` of the benchmark's family, the runner's loading:
``sensemaking.benchmark.datasets``, PointRCNN logits through a sigmoid there) with the situation
monitor on every sequence of ``../shared/data``, judges every event and HIDDEN_ENTITY /
SUDDEN_STOP / OVERTAKING warning against the ground truth
(``sensemaking.evaluation.explanations``, method in docs/EXPLANATIONS.md) and prints the
explanation-quality table per benchmark (markdown).

    nice -n 10 .venv/bin/python benchmarks/explanation_quality.py [--only kitti-rrc-car] \\
        [--data ../shared/data] [--json out.json] [--motion world|image]

``--motion world`` (default) gives the KITTI benchmarks the KITTI camera model, so the
situations judge motion over the road with the ego speed estimated from the scene
(``sensemaking.reasoning.egomotion``); ``--motion image`` judges it in image pixels (the
behaviour before), for comparison. MOT benchmarks have no camera model either way.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from sensemaking.benchmark.datasets import Benchmark, Sequence, default_data_root, iter_benchmarks
from sensemaking.benchmark.runner import ours_config
from sensemaking.detections import Detections
from sensemaking.errors import SensemakingError
from sensemaking.evaluation.explanations import (
    ExplanationResult,
    evaluate_explanations,
    explanation_table,
    load_ground_truth,
)
from sensemaking.io.atomic import atomic_write
from sensemaking.reasoning.egomotion import CameraModel
from sensemaking.reasoning.online import SituationMonitor
from sensemaking.settings import preset_profile
from sensemaking.tracker import Tracker


def track_sequence(
    bench: Benchmark, seq: Sequence, world: bool = True
) -> tuple[Detections, list, list[dict]]:
    """(visible track boxes, events, warning records) of our tracker on one sequence, as
    ``sensemaking track --events --warnings`` makes them (``world``: with the KITTI camera
    model on KITTI, as ``track --format kitti`` does)."""
    size = (int(seq.info.width), int(seq.info.height))
    config = ours_config(bench.spec.family, fps=float(seq.info.fps), image_size=size)
    tracker = Tracker(config)
    camera = CameraModel.kitti() if world and bench.spec.family == "kitti" else None
    monitor = SituationMonitor(
        fps=config.fps,
        image_size=config.image_size,
        profile=preset_profile(bench.spec.family),  # as `track` runs: the family's profile
        camera=camera,
    )
    frames = dict(seq.detections.frames())
    outputs, events, warnings = [], [], []
    for f in seq.frame_numbers:
        dets = frames.get(f, Detections.empty())
        result = tracker.update(dets, frame=f)
        outputs.append(result.visible)
        events += result.events
        warnings += [w.to_json() for w in monitor.update(result)]
    tracks = Detections.concatenate(outputs) if outputs else Detections.empty()
    return tracks, events, warnings


def judge_benchmark(bench: Benchmark, say=print, world: bool = True) -> list[ExplanationResult]:
    out = []
    for seq in bench.sequences:
        t0 = time.perf_counter()
        tracks, events, warnings = track_sequence(bench, seq, world)
        fmt = "kitti" if bench.spec.family == "kitti" else "mot"
        gt = load_ground_truth(
            seq.gt_path,
            fmt,
            image_size=(int(seq.info.width), int(seq.info.height)),
            fps=float(seq.info.fps),
            classes=(bench.spec.class_name or "pedestrian",),
            n_frames=int(seq.info.length),
        )
        out.append(evaluate_explanations(gt, tracks, events, warnings, name=seq.name))
        say(
            f"[{bench.name}] {seq.name}: {len(events)} events, {len(warnings)} warnings "
            f"({time.perf_counter() - t0:.1f} s)"
        )
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--data", type=Path, default=None, help="benchmark data (default ../shared/data)"
    )
    p.add_argument(
        "--only",
        action="append",
        default=None,
        metavar="NAME",
        help="benchmark name or glob (repeatable), e.g. kitti-rrc-car, mot17-*",
    )
    p.add_argument("--json", type=Path, default=None, help="write every verdict and summary here")
    p.add_argument(
        "--motion",
        choices=("world", "image"),
        default="world",
        help="judge motion over the road (camera model, KITTI) or in image pixels",
    )
    args = p.parse_args(argv)
    root = args.data or default_data_root()
    if not Path(root).is_dir():
        print(f"{root}: no benchmark data", file=sys.stderr)
        return 2
    results: dict[str, list[ExplanationResult]] = {}
    try:
        for bench in iter_benchmarks(root, args.only):
            results[bench.name] = judge_benchmark(
                bench,
                say=lambda m: print(m, file=sys.stderr, flush=True),
                world=args.motion == "world",
            )
    except SensemakingError as exc:
        print(f"explanation_quality: error: {exc}", file=sys.stderr)
        return 2
    print(explanation_table(results), end="")
    if args.json is not None:
        doc = {
            name: {
                "summary": ExplanationResult.combine(rs).summary(),
                "sequences": {
                    r.name: {
                        "events": [v.to_json() for v in r.events],
                        "warnings": [w.to_json() for w in r.warnings],
                    }
                    for r in rs
                },
            }
            for name, rs in results.items()
        }
        with atomic_write(args.json) as handle:
            handle.write(json.dumps(doc, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Digest of what the compiled modules compute, for tests/test_compiled.py.

    python tests/compiled_digest.py [--pure] [KITTI_DIR]

Runs the tracker and the SituationMonitor on the synthetic occlusion suite (the fast path and the
reference) and, when KITTI_DIR holds them, on two KITTI RRC car sequences (the fast path), plus the
per-frame helpers of relations and anticipation on random input, and prints one SHA-1 of every
warning, active situation, anticipation and helper result. With ``--pure`` the modules of
``sensemaking.reasoning.COMPILED`` are loaded from their Python sources even when compiled ones
are installed, so two runs compare the compiled modules with the pure-Python ones.
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.machinery
import importlib.util
import json
import sys
from pathlib import Path


class _PureSources(importlib.abc.MetaPathFinder):
    """Finds the listed modules as Python sources (``.py``) beside whatever is installed."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self.names = set(names)

    def find_spec(self, name, path=None, target=None):  # noqa: ANN001 - importlib's protocol
        if name not in self.names or not path:
            return None
        for folder in path:
            source = Path(folder) / (name.rsplit(".", 1)[-1] + ".py")
            if source.is_file():
                return importlib.util.spec_from_file_location(name, source)
        return None


def main(argv: list[str]) -> int:
    pure = "--pure" in argv
    args = [a for a in argv if a != "--pure"]
    if pure:
        from sensemaking.reasoning import COMPILED

        sys.meta_path.insert(0, _PureSources(COMPILED))
    import numpy as np

    from sensemaking.reasoning import anticipation, compiled, relations
    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.reasoning.situations import SituationConfig
    from sensemaking.synthetic import occlusion_suite
    from sensemaking.tracker import Tracker, TrackerConfig

    if pure and any(compiled().values()):
        print("--pure did not load the Python sources", file=sys.stderr)
        return 2
    h = hashlib.sha1()

    def add(obj) -> None:  # noqa: ANN001
        h.update(json.dumps(obj, sort_keys=True, default=repr).encode())

    runs = []  # (fps, image size, frame results, also the reference path?)
    for sc in occlusion_suite(0):
        tracker = Tracker(TrackerConfig(fps=sc.fps, image_size=(sc.width, sc.height)))
        runs.append((sc.fps, (sc.width, sc.height), [tracker.update(d, frame=f) for f, d in sc.frames()], True))
    kitti = Path(args[0]) if args else None
    if kitti is not None and (kitti / "detections" / "rrc" / "car" / "0001.txt").is_file():
        from sensemaking.detections import Detections
        from sensemaking.io.kitti import read_kitti_detections, read_kitti_seqinfo

        info = read_kitti_seqinfo(kitti / "training" / "seqinfo.csv")
        for seq in ("0001", "0009"):
            si = info[seq]
            by_frame = dict(read_kitti_detections(kitti / "detections" / "rrc" / "car" / f"{seq}.txt").frames())
            tracker = Tracker(TrackerConfig.for_dataset("kitti", fps=si.fps, image_size=(si.width, si.height)))
            runs.append((si.fps, (si.width, si.height),
                         [tracker.update(by_frame.get(f, Detections.empty()), frame=f) for f in range(si.length)], False))
    for fps, size, results, reference in runs:
        for prefilter in (True, False) if reference else (True,):
            mon = SituationMonitor(SituationConfig(prefilter=prefilter), fps=fps, image_size=size)
            for r in results:
                add([w.to_json() for w in mon.update(r)])
                add([w.to_json() for w in mon.active])
                add([a.to_json() for a in mon.anticipations])

    rng = np.random.default_rng(0)
    config, thresholds = relations.RelationConfig(), relations.MotionThresholds()
    for _ in range(300):
        xy = rng.uniform(0, 1000, (6, 2))
        boxes = np.concatenate([xy, xy + rng.uniform(1, 300, (6, 2))], axis=1).round(int(rng.integers(0, 3))).tolist()
        add(relations.near_depth_order(boxes, config))
        add(relations.near_pair_codes(boxes, config))
        add(relations.motion_row(boxes[0], boxes[1], float(rng.uniform(0.05, 1)), float(rng.uniform(0, 80)),
                                 thresholds))
        frames = sorted(rng.choice(30, 5, replace=False).tolist())
        add(anticipation.fit_motion_rows(frames, boxes[:5], 5, 10.0))
        add(anticipation._first_uncovered(frames[-1], boxes[0], [float(v) for v in rng.normal(0, 5, 4)], frames[-1],
                                          boxes[1], [float(v) for v in rng.normal(0, 5, 4)], frames[-1] + 1, 50, 0.5))
    print(h.hexdigest())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

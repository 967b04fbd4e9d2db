"""All classes at once against one run per class: KITTI PointRCNN, car + pedestrian + cyclist.

For every KITTI sequence of ``../shared/data`` this runs ``sensemaking track`` (in process, the
user's path) once on the three PointRCNN class files together (``--output DIR/joint/{class}/``)
and once per class file (``DIR/separate/<class>/``), scores car and pedestrian of both with the
same evaluation (``sensemaking evaluate``'s loaders and TrackEval's KITTI rules) and prints the
per-class HOTA side by side, then counts the joint runs' ``hides_behind`` events by the classes
of the hidden track and the occluder and judges them against the multi-class ground truth
(``sensemaking.evaluation.explanations``).

    nice -n 10 .venv/bin/python benchmarks/multiclass_joint.py [--data ../shared/data] \\
        [--out DIR] [--only 0000,0002] [--set inherit_motion=false ...]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

from sensemaking.benchmark.datasets import default_data_root
from sensemaking.cli import main as cli
from sensemaking.detections import Detections
from sensemaking.evaluation import evaluate, load_kitti_benchmark, rules_for_benchmark
from sensemaking.evaluation.explanations import GroundTruth, evaluate_explanations
from sensemaking.io.kitti import read_kitti_labels, read_kitti_seqinfo
from sensemaking.records import event_from_record

CLASSES = ("car", "pedestrian", "cyclist")
SCORED = ("car", "pedestrian")


def track(data: Path, out: Path, seq: str, extra: list[str]) -> None:
    dets = data / "kitti" / "detections" / "pointrcnn"
    files = [str(dets / c / f"{seq}.txt") for c in CLASSES]
    events = str(out / "joint" / "events" / f"{seq}.jsonl")
    common = ["-q", "track", "--format", "kitti", *extra]
    if (
        cli(
            [
                *common,
                "--detections",
                *files,
                "--events",
                events,
                "--output",
                str(out / "joint" / "{class}" / f"{seq}.txt"),
            ]
        )
        != 0
    ):
        sys.exit(f"joint run of {seq} failed")
    for c, f in zip(CLASSES, files, strict=True):
        if cli([*common, "--detections", f, "--output", str(out / "separate" / c / f"{seq}.txt")]):
            sys.exit(f"{c} run of {seq} failed")


def hota(data: Path, results: Path, cls: str, seqs: list[str]) -> float:
    """Combined HOTA of ``cls`` over ``seqs`` (fraction)."""
    inputs = load_kitti_benchmark(data / "kitti" / "training", results, missing_as_empty=True)
    report = evaluate({s: inputs[s] for s in seqs}, rules_for_benchmark("kitti", [cls]))
    return float(report.combined(cls)["HOTA"])


def cross_class_hides(data: Path, out: Path, seqs: list[str]) -> Counter:
    """(hidden class, occluder class, verdict) -> count over the joint runs' hides_behind."""
    training = data / "kitti" / "training"
    info = read_kitti_seqinfo(training / "seqinfo.csv")
    tally: Counter = Counter()
    for seq in seqs:
        parts, cls = [], {}
        for c in CLASSES:
            r = read_kitti_labels(out / "joint" / c / f"{seq}.txt")
            parts.append(r)
            cls.update(dict.fromkeys(r.tracker_id.tolist(), c))
        events = [
            event_from_record(json.loads(line))
            for line in (out / "joint" / "events" / f"{seq}.jsonl").read_text().splitlines()
        ]
        s = info[seq]
        truth = GroundTruth.from_kitti(
            read_kitti_labels(training / "label_02" / f"{seq}.txt"),
            image_size=(s.width, s.height),
            fps=s.fps,
            classes=CLASSES,
            n_frames=s.length,
        )
        result = evaluate_explanations(truth, Detections.concatenate(parts), events, name=seq)
        for v in result.events:
            if v.event.name == "hides_behind":
                t, o = v.event.args
                # an occluder never output (a tentative track) has no class in the results
                tally[(cls.get(t, "?"), cls.get(o, "not output"), v.verdict)] += 1
    return tally


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=None, help="keep the runs here")
    ap.add_argument("--set", dest="params", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--only", default=None, help="comma-separated sequences (default: all)")
    args = ap.parse_args()
    data = args.data or default_data_root()
    if not (data / "kitti" / "detections" / "pointrcnn").is_dir():
        print(f"no KITTI PointRCNN detections under {data}", file=sys.stderr)
        return 2
    out = args.out or Path(tempfile.mkdtemp(prefix="multiclass-"))
    seqs = sorted(read_kitti_seqinfo(data / "kitti" / "training" / "seqinfo.csv"))
    if args.only:
        seqs = [s for s in seqs if s in args.only.split(",")]
    extra = [x for p in args.params for x in ("--set", p)]
    for seq in seqs:
        track(data, out, seq, extra)
        print(f"tracked {seq}", file=sys.stderr)
    print(f"KITTI PointRCNN, {len(seqs)} sequences; runs in {out}")
    print("| class | HOTA joint | HOTA separate | joint - separate |")
    print("|---|---:|---:|---:|")
    for c in SCORED:
        joint = hota(data, out / "joint" / c, c, seqs)
        sep = hota(data, out / "separate" / c, c, seqs)
        print(f"| {c} | {100 * joint:.3f} | {100 * sep:.3f} | {100 * (joint - sep):+.3f} |")
    print("\nhides_behind in the joint runs: hidden class, occluder class, verdict")
    for (t, o, v), n in sorted(cross_class_hides(data, out, seqs).items()):
        print(f"  {t:10s} behind {o:10s} {v:12s} {n}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""``sensemaking evaluate``: score tracker output against ground truth (HOTA, CLEAR MOT, IDF1).

Examples::

    sensemaking evaluate --gt data/mot17 --results runs/mot17 --benchmark mot17 --json scores.json
    sensemaking evaluate --gt data/kitti/training --results runs/kitti --benchmark kitti \\
        --classes car --idsw-mode kitti_legacy
    sensemaking evaluate --gt MOT17-09/gt/gt.txt --results MOT17-09.txt
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from sensemaking.errors import InputError

log = logging.getLogger(__name__)

_BENCHMARKS = ("mot17", "mot16", "mot20", "mot15", "kitti")
_FORMAT_OF = {"mot17": "mot", "mot16": "mot", "mot20": "mot", "mot15": "mot", "kitti": "kitti"}


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "evaluate",
        help="score tracker output against ground truth (HOTA, CLEAR MOT, IDF1)",
        description=(
            "Score tracker results against ground truth with TrackEval's metrics and dataset rules "
            "(MOTChallenge, KITTI). --gt and --results are files (one sequence) or folders: "
            "MOTChallenge <gt>/<seq>/gt/gt.txt + <results>/<seq>.txt; KITTI <gt>/label_02/<seq>.txt "
            "(+ seqinfo.csv) + <results>/<seq>.txt. Prints a table (percentages); --json writes "
            "every field as fractions in [0, 1]."
        ),
        epilog=(
            "ID switches: 'trackeval' counts a switch whenever a gt object's track id changes, even "
            "across frames where it was not tracked; 'kitti_legacy' follows the old KITTI devkit, "
            "which counts one only when the object was tracked in its previous labelled frame. "
            "The table and the JSON name the mode used."
        ),
    )
    p.add_argument("--gt", required=True, type=Path, metavar="PATH", help="ground-truth file or folder")
    p.add_argument("--results", required=True, type=Path, metavar="PATH", help="tracker results file or folder")
    p.add_argument("--format", choices=("mot", "kitti"), help="file format (default: from --benchmark or the files)")
    p.add_argument("--benchmark", choices=_BENCHMARKS,
                   help="dataset rules (default: mot17 for 9-column MOT ground truth, mot15 for 10 "
                        "columns, kitti for KITTI)")
    p.add_argument("--classes", metavar="LIST",
                   help="comma-separated classes to score (KITTI: car,pedestrian, the default)")
    p.add_argument("--idsw-mode", choices=("trackeval", "kitti_legacy"), default="trackeval",
                   help="ID-switch / fragmentation rule (default: trackeval)")
    p.add_argument("--seqmap", type=Path, metavar="PATH", help="file listing the sequences to score")
    p.add_argument("--missing-as-empty", action="store_true",
                   help="score a sequence without a results file as empty tracker output (else an error)")
    p.add_argument("--json", type=Path, metavar="OUT", help="write every metric to this JSON file")
    p.set_defaults(func=run, _parser=p)


def _sniff_gt(gt: Path) -> tuple[str, str | None]:
    """(format, MOT benchmark guess) from the ground-truth path."""
    if gt.is_dir():
        if (gt / "label_02").is_dir() or gt.name == "label_02":
            return "kitti", None
        sample = gt / "gt" / "gt.txt"
        if not sample.is_file():
            found = sorted(gt.glob("*/gt/gt.txt"))
            sample = found[0] if found else None
        if sample is None:
            if any(gt.glob("*.txt")):
                return "kitti", None
            raise InputError("no ground truth found: expected <seq>/gt/gt.txt or label_02/<seq>.txt inside", gt)
    else:
        sample = gt
    try:
        with open(sample, encoding="utf-8") as handle:
            line = next((ln for ln in handle if ln.strip()), "")
    except FileNotFoundError:
        raise InputError("no such file or folder", sample) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read: {exc}", sample) from None
    if "," not in line and len(line.split()) in (17, 18):
        return "kitti", None
    n = len(line.split(","))
    return "mot", ("mot15" if n == 10 else "mot17")


def run(args: argparse.Namespace) -> int:
    from sensemaking.evaluation import evaluate, load_kitti_benchmark, load_mot_benchmark, rules_for_benchmark
    from sensemaking.io.atomic import atomic_write

    from sensemaking.io.sinks import check_output_paths

    parser: argparse.ArgumentParser = args._parser
    check_output_paths(
        {"--json": args.json}, {"--gt": args.gt, "--results": args.results, "--seqmap": args.seqmap}
    )
    fmt, benchmark = args.format, args.benchmark
    if benchmark is not None:
        implied = _FORMAT_OF[benchmark]
        if fmt is not None and fmt != implied:
            parser.error(f"--benchmark {benchmark} needs --format {implied}, not {fmt}")
        fmt = implied
    if fmt is None or benchmark is None:
        sniffed_fmt, guess = _sniff_gt(args.gt)
        fmt = fmt or sniffed_fmt
        if benchmark is None:
            benchmark = "kitti" if fmt == "kitti" else (guess or "mot17")
            log.info("scoring with %s rules (use --benchmark to choose)", benchmark)
    classes = [c.strip() for c in args.classes.split(",") if c.strip()] if args.classes else None
    try:
        rules = rules_for_benchmark(benchmark, classes)
    except ValueError as exc:
        parser.error(str(exc))

    load = load_kitti_benchmark if fmt == "kitti" else load_mot_benchmark
    sequences = load(args.gt, args.results, seqmap=args.seqmap, missing_as_empty=args.missing_as_empty)
    report = evaluate(sequences, rules, idsw_mode=args.idsw_mode)
    print(report.table(), end="")
    if args.json is not None:
        with atomic_write(args.json) as handle:
            handle.write(report.to_json() + "\n")
        log.info("wrote %s", args.json)
    return 0

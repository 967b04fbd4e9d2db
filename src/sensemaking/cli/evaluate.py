"""``sensemaking evaluate``: score tracker output against ground truth (HOTA, CLEAR MOT, IDF1).

Examples::

    sensemaking evaluate --gt data/mot17 --results runs/mot17 --benchmark mot17 --json scores.json
    sensemaking evaluate --gt data/kitti/training --results runs/kitti --benchmark kitti \\
        --classes car --idsw-mode kitti_legacy
    sensemaking evaluate --gt MOT17-09/gt/gt.txt --results MOT17-09.txt
    sensemaking evaluate --explanations --gt data/kitti/training/label_02/0001.txt \\
        --results runs/0001.txt --events runs/0001.events.jsonl \\
        --warnings runs/0001.warnings.jsonl --classes car
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

from sensemaking.errors import InputError

log = logging.getLogger(__name__)

_BENCHMARKS = ("mot17", "mot16", "mot20", "mot15", "kitti")
_FORMAT_OF = {"mot17": "mot", "mot16": "mot", "mot20": "mot", "mot15": "mot", "kitti": "kitti"}


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "evaluate",
        help="score tracker output against ground truth (HOTA, CLEAR MOT, IDF1), or judge "
        "its explanations (--explanations)",
        description=(
            "Score tracker results against ground truth with TrackEval's metrics and dataset "
            "rules (MOTChallenge, KITTI). --gt and --results are files (one sequence) or folders: "
            "MOTChallenge <gt>/<seq>/gt/gt.txt + <results>/<seq>.txt; "
            "KITTI <gt>/label_02/<seq>.txt (+ seqinfo.csv) + <results>/<seq>.txt. "
            "Prints a table (percentages) and identity through occlusion (KITTI, MOT17/16/20: "
            "episodes where a ground-truth object is hidden and seen again; kept / switched / "
            "lost / not tracked before, by gap length; sensemaking.evaluation.occlusion); "
            "--json writes every field as fractions in [0, 1], the occlusion counts under "
            '"occlusion".'
        ),
        epilog=(
            "ID switches: 'trackeval' counts a switch whenever a gt object's track id changes, "
            "even across frames where it was not tracked; "
            "'kitti_legacy' follows the old KITTI devkit, "
            "which counts one only when the object was tracked in its previous labelled frame. "
            "The table and the JSON name the mode used."
        ),
    )
    p.add_argument(
        "--gt", required=True, type=Path, metavar="PATH", help="ground-truth file or folder"
    )
    p.add_argument(
        "--results",
        required=True,
        type=Path,
        metavar="PATH",
        help="tracker results file or folder",
    )
    p.add_argument(
        "--format",
        choices=("mot", "kitti"),
        help="file format (default: from --benchmark or the files)",
    )
    p.add_argument(
        "--benchmark",
        choices=_BENCHMARKS,
        help="dataset rules (default: mot17 for 9-column MOT ground truth, mot15 for 10 "
        "columns, kitti for KITTI)",
    )
    p.add_argument(
        "--classes",
        metavar="LIST",
        help="comma-separated classes to score (KITTI: car,pedestrian, the default)",
    )
    p.add_argument(
        "--idsw-mode",
        choices=("trackeval", "kitti_legacy"),
        default="trackeval",
        help="ID-switch / fragmentation rule (default: trackeval)",
    )
    p.add_argument(
        "--seqmap", type=Path, metavar="PATH", help="file listing the sequences to score"
    )
    p.add_argument(
        "--missing-as-empty",
        action="store_true",
        help="score a sequence without a results file as empty tracker output (else an error)",
    )
    p.add_argument("--json", type=Path, metavar="OUT", help="write every metric to this JSON file")
    x = p.add_argument_group(
        "explanations",
        "--explanations judges the tracker's events and warnings against the ground truth "
        "instead of scoring the tracks (method and thresholds: docs/EXPLANATIONS.md). "
        "--results must hold the visible tracks only (`track` without --write-hidden); --json "
        "then writes every verdict.",
    )
    x.add_argument(
        "--explanations",
        action="store_true",
        help="judge events (and warnings) instead of scoring tracks",
    )
    x.add_argument(
        "--events",
        type=Path,
        metavar="PATH",
        help="event log of `track --events` (JSON lines): a file, or a folder of "
        "<seq>.jsonl / <seq>.events.jsonl",
    )
    x.add_argument(
        "--warnings",
        type=Path,
        metavar="PATH",
        help="warnings of `track --warnings` (JSON lines): a file, or a folder of "
        "<seq>.jsonl / <seq>.warnings.jsonl (optional)",
    )
    x.add_argument(
        "--image-size",
        metavar="WxH",
        help="image size in pixels when no seqinfo is found (e.g. 1242x375)",
    )
    x.add_argument("--fps", type=float, help="frame rate when no seqinfo is found")
    x.add_argument(
        "--html",
        type=Path,
        metavar="OUT",
        help="also write a self-contained HTML page: the precision-recall curve (inline SVG) of "
        "each event kind with a confidence, and the tables",
    )
    p.set_defaults(func=run, _parser=p)


def _sniff_gt(gt: Path) -> tuple[str, str | None]:
    """(format, MOT benchmark guess) from the ground-truth path."""
    if gt.is_dir():
        if (gt / "label_02").is_dir() or gt.name == "label_02":
            return "kitti", None
        found = [gt / "gt" / "gt.txt"]
        if not found[0].is_file():
            found = sorted(gt.glob("*/gt/gt.txt"))
        if not found:
            if any(gt.glob("*.txt")):
                return "kitti", None
            raise InputError(
                "no ground truth found: expected <seq>/gt/gt.txt or label_02/<seq>.txt inside", gt
            )
        sample = found[0]
    else:
        sample = gt
    from sensemaking.io.tables import first_line

    if not sample.exists():
        raise InputError("no such file or folder", sample)
    found_line = first_line(sample)
    line = "" if found_line is None else found_line[1]
    if "," not in line and len(line.split()) in (17, 18):
        return "kitti", None
    n = len(line.split(","))
    return "mot", ("mot15" if n == 10 else "mot17")


def run(args: argparse.Namespace) -> int:
    from sensemaking.evaluation import (
        evaluate,
        load_kitti_benchmark,
        load_mot_benchmark,
        rules_for_benchmark,
    )
    from sensemaking.io.atomic import atomic_write
    from sensemaking.sinks import check_output_paths

    parser: argparse.ArgumentParser = args._parser
    html_out = getattr(args, "html", None)
    if html_out is not None and not args.explanations:
        parser.error("--html goes with --explanations")
    check_output_paths(
        {"--json": args.json, "--html": html_out},
        {
            "--gt": args.gt,
            "--results": args.results,
            "--seqmap": args.seqmap,
            "--events": args.events,
            "--warnings": args.warnings,
        },
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
        # explanations of a joint run are judged for any KITTI type (cyclists); scores are not
        if not (args.explanations and fmt == "kitti" and _kitti_types(classes)):
            parser.error(str(exc))

    load = load_kitti_benchmark if fmt == "kitti" else load_mot_benchmark
    if args.explanations:
        return _explanations(args, fmt, benchmark, classes, load)
    if args.events is not None or args.warnings is not None:
        parser.error("--events and --warnings go with --explanations")
    sequences = load(
        args.gt, args.results, seqmap=args.seqmap, missing_as_empty=args.missing_as_empty
    )
    report = evaluate(sequences, rules, idsw_mode=args.idsw_mode)
    print(report.table(), end="")
    occlusion = _occlusion(sequences, fmt, benchmark, classes)
    if args.json is not None:
        doc = report.to_dict()
        if occlusion is not None:
            doc["occlusion"] = occlusion
        with atomic_write(args.json) as handle:
            handle.write(json.dumps(doc, indent=2, allow_nan=False) + "\n")
        log.info("wrote %s", args.json)
    return 0


def _occlusion(
    sequences: dict, fmt: str, benchmark: str, classes: list[str] | None
) -> dict | None:
    """Identity through occlusion (sensemaking.evaluation.occlusion): printed, and returned
    for --json; None for ground truth without visibility (MOT15)."""
    from sensemaking.evaluation.occlusion import (
        OcclusionCounts,
        benchmark_occlusion,
        occlusion_json,
        occlusion_table,
    )

    if fmt != "kitti" and benchmark == "mot15":
        return None
    fps = {n: _sequence_facts(fmt, Path(s.gt_path), n)[1] or 30.0 for n, s in sequences.items()}
    episodes = benchmark_occlusion(sequences, fmt, classes or ("car", "pedestrian"), fps)
    for label, per_seq in episodes.items():
        counts = {n: OcclusionCounts.of(e) for n, e in per_seq.items()}
        print()
        print(occlusion_table(counts, f"{benchmark} / {label}"), end="")
    return occlusion_json(episodes)


def _kitti_types(classes: list[str] | None) -> bool:
    """Every name is a KITTI object type (the explanation judge matches any of them)."""
    from sensemaking.classes import KITTI_NAMES, class_id

    try:
        return bool(classes) and all(class_id(c) in KITTI_NAMES for c in classes or ())
    except KeyError:
        return False


# -- --explanations ----------------------------------------------------------------------------
def _per_sequence(path: Path | None, names: list[str], suffix: str) -> dict[str, Path | None]:
    """The file of each sequence: ``path`` itself (one sequence) or ``<path>/<seq>.jsonl`` /
    ``<path>/<seq>.<suffix>.jsonl``."""
    if path is None:
        return dict.fromkeys(names)
    if path.is_file():
        if len(names) != 1:
            raise InputError(
                f"is a single file, but {len(names)} sequences are judged; give a "
                "folder of <sequence>.jsonl files",
                path,
            )
        return {names[0]: path}
    if not path.is_dir():
        raise InputError("no such file or folder", path)
    out: dict[str, Path | None] = {}
    for name in names:
        candidates = (path / f"{name}.jsonl", path / f"{name}.{suffix}.jsonl")
        found = [p for p in candidates if p.is_file()]
        if not found:
            raise InputError(f"no {name}.jsonl or {name}.{suffix}.jsonl", path)
        out[name] = found[0]
    return out


def _sequence_facts(
    fmt: str, gt_path: Path, name: str
) -> tuple[tuple[int, int] | None, float | None]:
    """(image size, fps) from the seqinfo beside the ground truth, when there is one."""
    if fmt == "kitti":
        from sensemaking.io.kitti import read_kitti_seqinfo

        for root in (gt_path.parent, gt_path.parent.parent):
            csv = root / "seqinfo.csv"
            if csv.is_file():
                info = read_kitti_seqinfo(csv).get(name)
                if info is not None:
                    return (info.width, info.height), info.fps
        return None, None
    from sensemaking.io.mot import read_seqinfo

    ini = gt_path.parent.parent / "seqinfo.ini"
    if ini.is_file():
        info = read_seqinfo(ini)
        return (info.width, info.height), info.fps
    return None, None


def _explanations(
    args: argparse.Namespace, fmt: str, benchmark: str, classes: list[str] | None, load
) -> int:

    from sensemaking.config import parse_size
    from sensemaking.evaluation.explanations import (
        ExplanationResult,
        GroundTruth,
        confidence_text,
        evaluate_explanations,
        explanation_table,
    )
    from sensemaking.io.atomic import atomic_write
    from sensemaking.records import read_events, read_warnings

    if args.events is None:
        args._parser.error("--explanations needs --events (the event log of `track --events`)")
    if args.fps is not None and not args.fps > 0:
        raise InputError(f"--fps must be positive, got {args.fps}")
    size_arg = parse_size(args.image_size) if args.image_size else None
    sequences = load(
        args.gt, args.results, seqmap=args.seqmap, missing_as_empty=args.missing_as_empty
    )
    names = list(sequences)
    events = _per_sequence(args.events, names, "events")
    warnings = _per_sequence(args.warnings, names, "warnings")
    results = []
    for name, s in sequences.items():
        size, fps = _sequence_facts(fmt, Path(s.gt_path), name)
        size, fps = size_arg or size, args.fps or fps
        if size is None:
            raise InputError(
                "no seqinfo found for the image size: pass --image-size WxH", s.gt_path
            )
        if fps is None:
            fps = 10.0 if fmt == "kitti" else 30.0
        if fmt == "kitti":
            gt = GroundTruth.from_kitti(
                s.gt,
                image_size=size,
                fps=fps,
                classes=classes or ("car", "pedestrian"),
                n_frames=s.n_frames,
            )
        else:
            gt = GroundTruth.from_mot(s.gt, image_size=size, fps=fps, n_frames=s.n_frames)
        events_path, warnings_path = events[name], warnings[name]
        assert events_path is not None  # --events is required above
        evs = read_events(events_path)
        ws = read_warnings(warnings_path) if warnings_path is not None else []
        results.append(evaluate_explanations(gt, s.tracks, evs, ws, name=name))
    label = benchmark + (f"/{','.join(classes)}" if classes else "")
    print(explanation_table({label: results}), end="")
    curve = confidence_text({label: results})
    if curve:
        print("\n" + curve, end="")
    if args.html is not None:
        from sensemaking.evaluation.curves import explanations_html

        with atomic_write(args.html) as handle:
            handle.write(explanations_html({label: results}))
        log.info("wrote %s", args.html)
    if args.json is not None:
        doc = {
            "benchmark": benchmark,
            "summary": ExplanationResult.combine(results).summary(),
            "sequences": {
                r.name: {
                    "summary": r.summary(),
                    "events": [v.to_json() for v in r.events],
                    "warnings": [w.to_json() for w in r.warnings],
                }
                for r in results
            },
        }
        with atomic_write(args.json) as handle:
            handle.write(json.dumps(doc, indent=1) + "\n")
        log.info("wrote %s", args.json)
    return 0

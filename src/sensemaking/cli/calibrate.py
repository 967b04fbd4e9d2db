"""``sensemaking calibrate``: estimate a parameter file from annotated sequences."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calibrate",
        help="estimate tracker parameters from your annotated sequences (writes a --params file)",
        description="Match each detection to the ground truth of its frame and estimate score "
        "thresholds, min_hits, how long objects go missing and the border costs from what is "
        "seen; "
        "write them as a parameter file for `sensemaking track --params FILE`. Give --gt and "
        "--detections once per sequence, in the same order.",
    )
    p.add_argument(
        "--gt",
        action="append",
        required=True,
        type=Path,
        metavar="FILE",
        help="ground truth: MOT gt.txt or KITTI label_02 file (repeatable)",
    )
    p.add_argument(
        "--detections",
        action="append",
        required=True,
        type=Path,
        metavar="FILE",
        help="the detector's file of the same sequence (repeatable, same order as --gt)",
    )
    p.add_argument(
        "--format", choices=("mot", "kitti"), required=True, help="format of both files"
    )
    p.add_argument(
        "--class",
        dest="class_name",
        default=None,
        help="the class to calibrate (KITTI: car or pedestrian, required; MOT: pedestrian)",
    )
    p.add_argument(
        "--seqinfo",
        type=Path,
        default=None,
        help="seqinfo.ini (MOT) or seqinfo.csv (KITTI); "
        "by default looked up beside the detections",
    )
    p.add_argument("--fps", type=float, default=None, help="frame rate when no seqinfo says it")
    p.add_argument("--output", required=True, type=Path, help="the parameter file to write (JSON)")
    p.set_defaults(func=run)


def _sequence(args: argparse.Namespace, gt_path: Path, det_path: Path):
    from sensemaking import settings
    from sensemaking.calibrate import annotated_sequence
    from sensemaking.classes import class_id
    from sensemaking.cli.track import _sequence_info
    from sensemaking.errors import InputError
    from sensemaking.io.formats import read_detections

    fmt = args.format
    if not gt_path.is_file():
        raise InputError("ground-truth file not found", gt_path)
    if fmt == "kitti":
        from sensemaking.io.kitti import read_kitti_labels

        if args.class_name is None:
            raise InputError("--class is required with --format kitti (car or pedestrian)")
        try:
            cid = class_id(args.class_name)
        except KeyError:
            raise InputError(f"unknown class {args.class_name!r}") from None
        gt = read_kitti_labels(gt_path)
        first = 0
    else:
        from sensemaking.io.mot import read_mot

        cid = class_id(args.class_name or "pedestrian")
        gt = read_mot(gt_path, kind="gt", default_class=cid)
        first = 1
    dets = read_detections(det_path, fmt, class_name=args.class_name)
    if fmt == "kitti" and len(dets):  # PointRCNN files hold every class
        dets = dets[dets.class_id == cid]
    info = argparse.Namespace(detections=det_path, format=fmt, seqinfo=args.seqinfo)
    fps, size, length = _sequence_info(info)
    fps = args.fps if args.fps is not None else fps
    if fps is None:
        fps = settings.preset_config(fmt).fps
    settings.check_value("fps", fps)
    annotated: list[int] = []
    for x in (gt, dets):
        if len(x):
            assert x.frame is not None  # set by __post_init__
            annotated.append(int(x.frame.max()))
    last_gt = max(annotated) if annotated else first
    n_frames = int(length) if length else last_gt - first + 1
    if last_gt > first + n_frames - 1:
        raise InputError(
            f"ground truth reaches frame {last_gt}, beyond the sequence's {n_frames} frames",
            gt_path,
        )
    return annotated_sequence(
        det_path.stem if fmt == "kitti" else det_path.parent.parent.name,
        gt,
        dets,
        cid,
        first,
        n_frames,
        float(fps),
        size,
        path=str(det_path),
    )


def run(args: argparse.Namespace) -> int:
    from sensemaking import settings
    from sensemaking.calibrate import calibrate
    from sensemaking.errors import InputError

    if len(args.gt) != len(args.detections):
        raise InputError(
            f"give --gt and --detections once per sequence: got {len(args.gt)} --gt and "
            f"{len(args.detections)} --detections"
        )
    from sensemaking.cli.track import _seqinfo_candidates
    from sensemaking.sinks import check_output_paths

    inputs: dict[str, Path | None] = {"--seqinfo": args.seqinfo}
    for g, d in zip(args.gt, args.detections, strict=True):
        inputs.update({f"--gt {g}": g, f"--detections {d}": d})
        # the seqinfo found beside the detections is an input too
        info = argparse.Namespace(detections=d, format=args.format, seqinfo=args.seqinfo)
        inputs.update({f"seqinfo {c}": c for c in _seqinfo_candidates(info) if c.is_file()})
    check_output_paths({"--output": args.output}, inputs)
    sequences = [_sequence(args, g, d) for g, d in zip(args.gt, args.detections, strict=True)]
    if all(len(s.gt) == 0 for s in sequences):  # one video without the class is fine, all is not
        raise InputError(f"no ground truth of class {args.class_name or 'pedestrian'}", args.gt[0])
    try:
        result = calibrate(sequences)
    except InputError as exc:
        if exc.path is None and len(sequences) == 1:  # a fault of the one pair of files
            raise InputError(exc.problem, args.detections[0]) from None
        raise
    path = settings.write_params(
        args.output, result.params, source=result.source(), base=settings.family_name(args.format)
    )
    if not args.quiet:
        shown = ", ".join(f"{k}={v}" for k, v in result.params.items())
        print(f"{path}: {shown}")
    return 0

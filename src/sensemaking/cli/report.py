"""``sensemaking report``: one self-contained HTML page explaining a scene."""

from __future__ import annotations

import argparse
from pathlib import Path

from sensemaking.cli.render import add_warning_options, warnings_arg
from sensemaking.errors import InputError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report",
        help="write a self-contained HTML report: "
        "timeline, stories, warnings, metrics, key frames",
        description="Write one HTML file that opens offline: a timeline of every track's states "
        "and events, each track's story, the warnings, the metrics against ground truth "
        "(with --gt; with hidings in the run also their precision-recall curve against the "
        "confidence) and thumbnails of the key frames with the explanation drawn. "
        "Needs the 'viz' extra.",
    )
    p.add_argument("scene", type=Path, help="scene JSON written by `sensemaking track --scene`")
    p.add_argument("--output", "-o", required=True, type=Path, help="the HTML file to write")
    p.add_argument(
        "--gt", type=Path, default=None, help="ground truth (MOT gt.txt or KITTI label_02 file)"
    )
    p.add_argument(
        "--format",
        choices=("mot", "kitti"),
        default=None,
        help="format of --gt (default: guessed from the file)",
    )
    p.add_argument(
        "--idsw-mode",
        choices=("trackeval", "kitti_legacy"),
        default="trackeval",
        help="ID-switch rule of the metrics (default: trackeval)",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument(
        "--images", type=Path, help="folder of the sequence's images, for the thumbnails"
    )
    src.add_argument("--video", type=Path, help="video of the sequence, for the thumbnails")
    p.add_argument(
        "--first-frame",
        type=int,
        default=None,
        help="frame number of the first image / video frame when file names do not say it",
    )
    p.add_argument(
        "--thumbnails",
        type=int,
        default=24,
        metavar="N",
        help="at most N key-frame thumbnails (0: none)",
    )
    p.add_argument("--title", default=None, help="page title")
    add_warning_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from sensemaking.viz.report import write_report

    if args.format is not None and args.gt is None:
        raise InputError("--format describes --gt: give --gt too")
    if args.thumbnails < 0:
        raise InputError(f"--thumbnails must be >= 0, got {args.thumbnails}")
    from sensemaking.sinks import check_output_paths

    inputs = {
        "SCENE": args.scene,
        "--gt": args.gt,
        "--images": args.images,
        "--video": args.video,
        "--warnings": args.warnings,
    }
    check_output_paths({"--output": args.output}, inputs)
    out = write_report(
        args.scene,
        args.output,
        gt=args.gt,
        gt_format=args.format,
        images=args.images,
        video=args.video,
        first_frame=args.first_frame,
        title=args.title,
        warnings=warnings_arg(args),
        max_thumbnails=args.thumbnails,
        idsw_mode=args.idsw_mode,
    )
    if not args.quiet:
        print(f"{out}: report written")
    return 0

"""``sensemaking track``: detections file in, tracks (same format) and explanations out."""

from __future__ import annotations

import argparse
import logging
import math
import sys
from pathlib import Path
from typing import Any

from sensemaking.cli._progress import Progress
from sensemaking.errors import InputError

log = logging.getLogger(__name__)

#: option ranges (a frame rate or an image side beyond these is a typo, not a camera)
MIN_FPS, MAX_FPS = 0.01, 1000.0  # frames per second: a frame a 100 s .. a frame a ms
MAX_IMAGE_SIDE = 100_000


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "track",
        help="track a detections file (MOTChallenge or KITTI) and explain what happened",
        description="Online abductive tracking of a detections file. Writes tracks in the input's "
        "format and, optionally, the abduced events (JSON lines), the scene model and warnings.",
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument(
        "--detections", type=Path, help="detections file (MOT det.txt or a KITTI file)"
    )
    src.add_argument(
        "--source",
        type=Path,
        help="a video file or image folder to run --detector on (frames numbered from 1)",
    )
    p.add_argument(
        "--detector",
        type=Path,
        default=None,
        help="a local model file for --source: .onnx (extra 'detector') or ultralytics .pt "
        "(extra 'ultralytics'); nothing is downloaded. See docs/detectors.md",
    )
    p.add_argument(
        "--format",
        choices=("mot", "kitti"),
        default=None,
        help="format of input and output (required with --detections; --source writes mot)",
    )
    p.add_argument(
        "--output", required=True, type=Path, help="tracking results, in the input's format"
    )
    p.add_argument(
        "--events", type=Path, help='events as JSON lines {"frame":…, "event":…, "args":[…]}'
    )
    p.add_argument(
        "--scene",
        type=Path,
        help="the scene model (JSON) for `sensemaking ask/explain/render/report`",
    )
    p.add_argument(
        "--warnings",
        type=Path,
        help="safety-critical warnings as JSON lines, written online into PATH.part (follow it "
        "with tail -f), renamed to PATH at the end and kept when the run is interrupted",
    )
    p.add_argument(
        "--no-abduction", action="store_true", help="plain Hungarian IoU matching (the ablation)"
    )
    p.add_argument(
        "--max-solve-ms",
        type=float,
        default=None,
        metavar="MS",
        help="per-frame wall-clock budget for the solver, milliseconds (> 0); past it the best "
        "answer so far is used. Results then depend on the machine's load (a busy machine "
        "stops earlier): leave it out for reproducible runs",
    )
    p.add_argument(
        "--class",
        dest="class_name",
        default=None,
        help="class of the detections when the file does not say (e.g. car for KITTI RRC "
        "files; with --format kitti a KITTI type)",
    )
    p.add_argument(
        "--seqinfo",
        type=Path,
        default=None,
        help="seqinfo.ini (MOT) or seqinfo.csv (KITTI) for frame rate, image size and length; "
        "looked up beside the detections by default",
    )
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        help=f"frame rate, frames per second in [{MIN_FPS:g}, {MAX_FPS:g}] "
        "(default: seqinfo, else 30 MOT / 10 KITTI)",
    )
    p.add_argument(
        "--image-size",
        default=None,
        metavar="WxH",
        help=f"field of view in pixels, e.g. 1242x375 (each side 1..{MAX_IMAGE_SIDE})",
    )
    p.add_argument(
        "--write-hidden",
        action="store_true",
        help="also write hidden and missing tracks at their predicted boxes",
    )
    p.add_argument(
        "--set",
        dest="params",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a parameter, e.g. --set max_hidden_s=2 or --set costs.resumes=200 "
        "(repeatable; after --params; units and ranges in docs/PARAMETERS.md)",
    )
    p.add_argument(
        "--rules",
        type=Path,
        action="append",
        default=[],
        metavar="FILE",
        help="your own rules (.lp) added to the tracking encoding, e.g. a new event "
        "`occurs(stops(T)) :- track(T), speed(T,S), S < 5.` (repeatable)",
    )
    p.add_argument(
        "--encoding",
        type=Path,
        default=None,
        metavar="FILE",
        help="an encoding (.lp) that replaces the packaged tracking.lp",
    )
    p.add_argument(
        "--situations",
        type=Path,
        action="append",
        default=[],
        metavar="FILE",
        help="your own situations (.lp) added to situations.lp for --warnings, e.g. "
        "`warn(stopped_ahead,(T,)) :- ...` (repeatable)",
    )
    p.add_argument(
        "--ego-motion",
        type=Path,
        default=None,
        metavar="FILE",
        help="the camera vehicle's speed per frame for --warnings, CSV "
        "frame,speed_mps[,yaw_rate_rad_s] (docs/EGOMOTION.md); default: estimated from the "
        "scene (needs a camera model: --format kitti or --camera)",
    )
    p.add_argument(
        "--camera",
        default=None,
        metavar="F,H,HORIZON,CX",
        help="camera model for --warnings and the --scene stories: focal length px, height "
        "above the road m, horizon row px, principal column px (default with --format kitti: "
        "KITTI's camera; else none: motion judged in the image, as for a fixed camera)",
    )
    p.add_argument(
        "--params",
        dest="params_file",
        type=Path,
        default=None,
        metavar="FILE",
        help="a parameter file (JSON or TOML, e.g. from `sensemaking calibrate`) over the "
        "preset of --format",
    )
    p.set_defaults(func=run)


def parse_size(text: str, where: str = "--image-size") -> tuple[int, int]:
    try:
        w, h = text.lower().split("x")
        size = int(w), int(h)
    except ValueError:
        raise InputError(f"{where} must look like 1242x375, got {text!r}") from None
    if not all(1 <= v <= MAX_IMAGE_SIDE for v in size):
        raise InputError(f"{where}: each side must be 1..{MAX_IMAGE_SIDE} pixels, got {text!r}")
    return size


def check_fps(fps: float, where: str, path: Path | None = None) -> float:
    """A frame rate in [MIN_FPS, MAX_FPS] frames per second."""
    if not (math.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS):
        raise InputError(
            f"{where} must be a frame rate in [{MIN_FPS:g}, {MAX_FPS:g}] frames per second, "
            f"got {fps!r}",
            path,
        )
    return float(fps)


def _check_options(args: argparse.Namespace) -> None:
    """Every option's unit and range, before any file is read."""
    if args.fps is not None:
        check_fps(args.fps, "--fps")
    if args.max_solve_ms is not None and not (
        math.isfinite(args.max_solve_ms) and args.max_solve_ms > 0
    ):
        raise InputError(
            f"--max-solve-ms must be a positive number of milliseconds, got {args.max_solve_ms!r}"
            " (leave it out for no budget)"
        )
    if args.image_size is not None:
        parse_size(args.image_size)
    if args.class_name is not None:
        from sensemaking.classes import KITTI_NAMES
        from sensemaking.io.tables import class_id_of

        cid = class_id_of(args.class_name)
        if args.format == "kitti" and cid not in KITTI_NAMES:
            raise InputError(
                f"--class {args.class_name}: KITTI results have no type for it (KITTI types: "
                f"{', '.join(KITTI_NAMES.values())})"
            )


def _sequence_info(
    args: argparse.Namespace,
) -> tuple[float | None, tuple[int, int] | None, int | None]:
    """(fps, image size, number of frames) from seqinfo files, when found."""
    det = args.detections
    if args.seqinfo is not None and not args.seqinfo.is_file():
        raise InputError(
            "seqinfo file not found" if not args.seqinfo.exists() else "seqinfo is not a file",
            args.seqinfo,
        )
    if args.format == "mot":
        from sensemaking.io.mot import read_seqinfo

        candidates = (
            [args.seqinfo]
            if args.seqinfo
            else [det.parent.parent / "seqinfo.ini", det.parent / "seqinfo.ini"]
        )
        for c in candidates:
            if c.is_file():
                info = read_seqinfo(c)
                return check_fps(info.fps, "frameRate", c), _checked_size(info, c), info.length
        return None, None, None
    from sensemaking.io.kitti import read_kitti_seqinfo

    candidates = (
        [args.seqinfo]
        if args.seqinfo
        else [p / "seqinfo.csv" for p in det.parents[:4]]
        + [p / "training" / "seqinfo.csv" for p in det.parents[:5]]
    )
    for c in candidates:
        if c.is_file():
            found = read_kitti_seqinfo(c).get(det.stem)
            if found is not None:
                return check_fps(found.fps, "frame_rate", c), _checked_size(found, c), found.length
    if args.seqinfo:
        raise InputError(
            f"sequence {det.stem!r} (the detection file's name) is not in seqinfo", args.seqinfo
        )
    return None, None, None


def _checked_size(info: Any, path: Path) -> tuple[int, int]:
    if not (info.width <= MAX_IMAGE_SIDE and info.height <= MAX_IMAGE_SIDE):
        raise InputError(
            f"image size {info.width}x{info.height} is implausible (each side at most "
            f"{MAX_IMAGE_SIDE} pixels)",
            path,
        )
    return info.width, info.height


def tracker_config(args: argparse.Namespace, fps: float | None, size: tuple[int, int] | None):
    """The family preset of ``--format``, then ``--params FILE``, the input's facts and switches,
    then ``--set`` (each validated by :mod:`sensemaking.settings`)."""
    from sensemaking import settings

    family = "kitti" if args.format == "kitti" else "mot"
    facts: dict[str, Any] = {}
    if args.no_abduction:
        facts["abduction"] = False
    if args.max_solve_ms is not None:
        facts["max_solve_ms"] = args.max_solve_ms
    if getattr(args, "fps", None) is not None:  # 0 and nan are errors, not "unset"
        fps = args.fps
    if fps is not None:
        facts["fps"] = float(fps)
    if size:
        facts["image_size"] = size
    return settings.load_config(getattr(args, "params_file", None), family, facts, args.params)


def _file_frames(args: argparse.Namespace, config: Any, length: int | None):
    """(frames as (frame, Detections) pairs, first frame, last frame) of a detections file,
    checked whole before (so that a bad line stops the run before any work) and then read
    again frame by frame."""
    from sensemaking.io.stream import iter_detection_frames, scan_detections

    first = 1 if args.format == "mot" else 0
    seq_last = None if length is None else first + length - 1
    log.info("checking %s before tracking", args.detections)
    summary = scan_detections(
        args.detections,
        args.format,
        args.class_name,
        image_size=config.image_size,
        last_frame=seq_last,
    )
    last = summary.last
    if seq_last is not None:
        last = seq_last if last is None else max(last, seq_last)
    frames = iter_detection_frames(
        args.detections,
        args.format,
        args.class_name,
        image_size=config.image_size,
        last_frame=seq_last,
    )
    return frames, first, last


def _video_frames(args: argparse.Namespace):
    """The same for ``--source VIDEO --detector MODEL``: detections made frame by frame, and
    the image size (from the first frame)."""
    from sensemaking.detector import iter_video_frames, load_detector

    if args.detector is None:
        raise InputError("--source needs --detector MODEL (a local .onnx or .pt file)")
    if args.format not in (None, "mot"):
        raise InputError(
            "--source writes MOTChallenge results: use --format mot (or leave it out)"
        )
    args.format = "mot"
    detector = load_detector(args.detector)
    images = iter_video_frames(args.source)
    try:
        first = next(images)
    except StopIteration:
        raise InputError("no frames in the video", args.source) from None

    def frames():
        yield 1, detector(first, frame=1)
        for f, image in enumerate(images, start=2):
            yield f, detector(image, frame=f)

    return frames(), (int(first.shape[1]), int(first.shape[0]))


def _world_motion(args: argparse.Namespace) -> dict[str, Any]:
    """``camera`` and ``ego_motion`` of the SituationMonitor from --camera / --ego-motion."""
    from sensemaking.io.egomotion import read_ego_motion
    from sensemaking.reasoning.egomotion import CameraModel

    camera = CameraModel.parse(args.camera) if args.camera else None
    if camera is None and args.format == "kitti":
        camera = CameraModel.kitti()
    if args.ego_motion is not None and camera is None:
        raise InputError("--ego-motion needs a camera model: --format kitti or --camera")
    ego = None if args.ego_motion is None else read_ego_motion(args.ego_motion)
    return {"camera": camera, "ego_motion": ego}


def run(args: argparse.Namespace) -> int:
    from sensemaking.io.sinks import (
        EventsSink,
        SceneSink,
        TracksSink,
        WarningsSink,
        check_output_paths,
    )
    from sensemaking.pipeline import Pipeline
    from sensemaking.tracker import Tracker

    if args.detections is not None and args.format is None:
        raise InputError("--format mot|kitti is required with --detections")
    _check_options(args)
    outputs = {
        "--output": args.output,
        "--events": args.events,
        "--scene": args.scene,
        "--warnings": args.warnings,
    }
    inputs = {
        "--detections": args.detections,
        "--source": args.source,
        "--detector": args.detector,
        "--seqinfo": args.seqinfo,
        "--encoding": args.encoding,
        **{f"--rules {r}": r for r in args.rules},
        **{f"--situations {r}": r for r in args.situations},
        "--ego-motion": args.ego_motion,
    }
    check_output_paths(outputs, inputs)
    fps = size = length = None
    if args.detections is not None:
        fps, size, length = _sequence_info(args)
    else:
        frames, size = _video_frames(args)
    if args.fps:
        fps = args.fps
    if args.image_size:
        size = parse_size(args.image_size)
    config = tracker_config(args, fps, size)
    first = last = None
    if args.detections is not None:
        frames, first, last = _file_frames(args, config, length)
    tracker = Tracker(config, encoding=args.encoding, rules=args.rules)
    recorder = monitor = None
    if args.situations and not args.warnings:
        raise InputError("--situations needs --warnings PATH (where the warnings go)")
    if (args.ego_motion or args.camera) and not (args.warnings or args.scene):
        raise InputError("--ego-motion and --camera need --warnings or --scene (they serve those)")
    world = _world_motion(args)
    if args.warnings:
        from sensemaking.reasoning.online import SituationMonitor

        monitor = SituationMonitor(
            fps=config.fps,
            image_size=config.image_size,
            extra_encodings=args.situations,
            **world,
        )
    source = args.detections or args.source
    total = 0 if last is None or first is None else last - first + 1
    with Progress(total, "tracking", enabled=not args.quiet) as progress:
        sinks: list[Any] = []
        try:
            sinks.append(TracksSink(args.output, args.format, write_hidden=args.write_hidden))
            if args.events:
                sinks.append(EventsSink(args.events))
            if args.warnings:
                sinks.append(WarningsSink(args.warnings))
                log.info("warnings are written as they come into %s", sinks[-1].part)
            if args.scene:
                sinks.append(
                    SceneSink(
                        args.scene,
                        fps=config.fps,
                        image_size=config.image_size,
                        metadata={
                            "name": Path(source).stem,
                            "source": str(source),
                            **(
                                {"camera": world["camera"].to_json()}
                                if world["camera"] is not None
                                else {}
                            ),
                        },
                    )
                )
        except BaseException:
            from sensemaking.io.sinks import close_all

            close_all(sinks, ok=False)
            raise
        # a file's frames were checked by the reader (same bounds); a detector's are checked here
        pipe = Pipeline(
            tracker,
            recorder,
            monitor,
            sinks,
            validate=args.detections is None,
            on_frames=progress.advance,
        )
        try:
            with pipe:
                summary = pipe.run(frames, first_frame=first, last_frame=last)
        except KeyboardInterrupt:
            done = pipe.summary.last
            kept = (
                f"; the warnings issued so far are kept in {args.warnings}"
                if args.warnings
                else ""
            )
            print(
                f"sensemaking track: interrupted after frame {done}: no results written{kept}",
                file=sys.stderr,
            )
            raise
    stats = tracker.stats
    n_tracks, n_boxes = len(sinks[0].ids), sinks[0].boxes
    per_frame = stats["solve_ms"] / max(stats["frames"], 1)
    log.info(
        "tracked %d frames (%d stepped): %d boxes, %d tracks, %d events; solver %.2f ms/frame, "
        "%d over budget",
        summary.frames,
        summary.stepped,
        n_boxes,
        n_tracks,
        summary.events,
        per_frame,
        stats["timed_out"],
    )
    if not args.quiet:
        print(
            f"{args.output}: {n_tracks} tracks over {summary.frames} frames, "
            f"{summary.events} events ({per_frame:.2f} ms/frame association"
            + (
                f", {stats['timed_out']} frames over the solve budget"
                if stats["timed_out"]
                else ""
            )
            + ")"
        )
    return 0

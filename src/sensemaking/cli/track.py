"""``sensemaking track``: detections file in, tracks (same format) and explanations out."""

from __future__ import annotations

import argparse
import json
import logging
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.cli._progress import Progress
from sensemaking.detections import Detections
from sensemaking.errors import InputError, SensemakingError
from sensemaking.io.atomic import atomic_write

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "track",
        help="track a detections file (MOTChallenge or KITTI) and explain what happened",
        description="Online abductive tracking of a detections file. Writes tracks in the input's "
        "format and, optionally, the abduced events (JSON lines), the scene model and warnings.",
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--detections", type=Path, help="detections file (MOT det.txt or a KITTI file)")
    src.add_argument("--source", type=Path,
                     help="a video file or image folder to run --detector on (frames numbered from 1)")
    p.add_argument("--detector", type=Path, default=None,
                   help="a local model file for --source: .onnx (extra 'detector') or ultralytics .pt "
                   "(extra 'ultralytics'); nothing is downloaded. See docs/detectors.md")
    p.add_argument("--format", choices=("mot", "kitti"), default=None,
                   help="format of input and output (required with --detections; --source writes mot)")
    p.add_argument("--output", required=True, type=Path, help="tracking results, in the input's format")
    p.add_argument("--events", type=Path, help='events as JSON lines {"frame":…, "event":…, "args":[…]}')
    p.add_argument("--scene", type=Path, help="the scene model (JSON) for `sensemaking ask/explain/render/report`")
    p.add_argument("--warnings", type=Path, help="safety-critical warnings as JSON lines, written online")
    p.add_argument("--no-abduction", action="store_true", help="plain Hungarian IoU matching (the ablation)")
    p.add_argument("--max-solve-ms", type=float, default=None,
                   help="per-frame budget for the solver in ms; past it the best answer so far is used")
    p.add_argument("--class", dest="class_name", default=None,
                   help="class of the detections when the file does not say (e.g. car for KITTI RRC files)")
    p.add_argument("--seqinfo", type=Path, default=None,
                   help="seqinfo.ini (MOT) or seqinfo.csv (KITTI) for frame rate, image size and length; "
                   "looked up beside the detections by default")
    p.add_argument("--fps", type=float, default=None, help="frame rate (default: seqinfo, else 30 MOT / 10 KITTI)")
    p.add_argument("--image-size", default=None, metavar="WxH", help="field of view in pixels, e.g. 1242x375")
    p.add_argument("--write-hidden", action="store_true",
                   help="also write hidden and missing tracks at their predicted boxes")
    p.add_argument("--set", dest="params", action="append", default=[], metavar="KEY=VALUE",
                   help="override a parameter, e.g. --set max_hidden_s=2 or --set costs.resumes=200 "
                   "(repeatable; after --params; units and ranges in docs/PARAMETERS.md)")
    p.add_argument("--params", dest="params_file", type=Path, default=None, metavar="FILE",
                   help="a parameter file (JSON or TOML, e.g. from `sensemaking calibrate`) over the "
                   "preset of --format")
    p.set_defaults(func=run)


def parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = text.lower().split("x")
        size = int(w), int(h)
    except ValueError:
        raise InputError(f"--image-size must look like 1242x375, got {text!r}") from None
    if size[0] <= 0 or size[1] <= 0:
        raise InputError(f"--image-size must be positive, got {text!r}")
    return size


def _sequence_info(args: argparse.Namespace) -> tuple[float | None, tuple[int, int] | None, int | None]:
    """(fps, image size, number of frames) from seqinfo files, when found."""
    det = args.detections
    if args.format == "mot":
        from sensemaking.io.mot import read_seqinfo

        candidates = [args.seqinfo] if args.seqinfo else [det.parent.parent / "seqinfo.ini", det.parent / "seqinfo.ini"]
        for c in candidates:
            if c is not None and c.exists():
                info = read_seqinfo(c)
                return info.fps, (info.width, info.height), info.length
        if args.seqinfo:
            raise InputError("seqinfo file not found", args.seqinfo)
        return None, None, None
    from sensemaking.io.kitti import read_kitti_seqinfo

    candidates = [args.seqinfo] if args.seqinfo else [p / "seqinfo.csv" for p in det.parents[:4]] + [
        p / "training" / "seqinfo.csv" for p in det.parents[:5]]
    for c in candidates:
        if c is not None and c.exists():
            infos = read_kitti_seqinfo(c)
            info = infos.get(det.stem)
            if info is not None:
                return info.fps, (info.width, info.height), info.length
    if args.seqinfo:
        raise InputError(f"sequence {det.stem!r} not in seqinfo", args.seqinfo)
    return None, None, None


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


def frame_range(dets: Detections, fmt: str, length: int | None) -> range:
    """Every frame of the sequence, including those without detections."""
    first = 1 if fmt == "mot" else 0
    last = int(dets.frame.max()) if len(dets) else first - 1
    if length is not None:
        last = max(last, first + length - 1)
    return range(first, last + 1)


def _file_frames(args: argparse.Namespace):
    """(frames to track as (frame, Detections) pairs, count, fps, image size) from a detections file."""
    from sensemaking.io.formats import read_detections

    if args.format is None:
        raise InputError("--format mot|kitti is required with --detections")
    dets = read_detections(args.detections, args.format, class_name=args.class_name)
    fps, size, length = _sequence_info(args)
    frames = frame_range(dets, args.format, length)
    by_frame = dict(dets.frames())
    return ((f, by_frame.get(f, Detections.empty())) for f in frames), len(frames), fps, size


def _video_frames(args: argparse.Namespace):
    """The same for ``--source VIDEO --detector MODEL``: detections made frame by frame."""
    from sensemaking.detector import iter_video_frames, load_detector

    if args.detector is None:
        raise InputError("--source needs --detector MODEL (a local .onnx or .pt file)")
    if args.format not in (None, "mot"):
        raise InputError("--source writes MOTChallenge results: use --format mot (or leave it out)")
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

    return frames(), 0, None, (int(first.shape[1]), int(first.shape[0]))


def run(args: argparse.Namespace) -> int:
    from sensemaking.io.formats import write_results
    from sensemaking.tracker import Tracker

    frames, n_frames, fps, size = _video_frames(args) if args.source else _file_frames(args)
    if args.fps:
        fps = args.fps
    if args.image_size:
        size = parse_size(args.image_size)
    config = tracker_config(args, fps, size)
    tracker = Tracker(config)
    outputs: list[Detections] = []
    n_events = 0
    recorder = _optional_recorder(args, config)
    monitor = _optional_monitor(args, config)
    with ExitStack() as stack:
        events_out = stack.enter_context(atomic_write(args.events)) if args.events else None
        warnings_out = stack.enter_context(atomic_write(args.warnings)) if args.warnings else None
        progress = stack.enter_context(Progress(n_frames, "tracking", enabled=not args.quiet))
        for f, frame_dets in frames:
            result = tracker.update(frame_dets, frame=f)
            outputs.append(result.tracks if args.write_hidden else result.visible)
            if events_out is not None:
                for ev in result.events:
                    events_out.write(json.dumps(ev.to_json()) + "\n")
            n_events += len(result.events)
            if recorder is not None:
                recorder.add(result)
            if monitor is not None:
                for w in monitor.update(result):
                    if warnings_out is not None:
                        warnings_out.write(json.dumps(w.to_json()) + "\n")
                        warnings_out.flush()
            progress.advance()
        tracks = Detections.concatenate(outputs) if outputs else Detections.empty()
        write_results(args.output, tracks, args.format)
        if recorder is not None:
            recorder.scene().save(args.scene)
    stats = tracker.stats
    log.info("tracked %d frames: %d boxes, %d tracks, %d events; solver %.2f ms/frame, %d over budget",
             stats["frames"], len(tracks), len(np.unique(tracks.tracker_id)), n_events,
             stats["solve_ms"] / max(stats["frames"], 1), stats["timed_out"])
    if not args.quiet:
        print(f"{args.output}: {len(np.unique(tracks.tracker_id))} tracks over {stats['frames']} frames, "
              f"{n_events} events ({stats['solve_ms'] / max(stats['frames'], 1):.2f} ms/frame association"
              + (f", {stats['timed_out']} frames over the solve budget" if stats["timed_out"] else "") + ")")
    return 0


def _optional_recorder(args: argparse.Namespace, config) -> Any:
    if not args.scene:
        return None
    try:
        from sensemaking.scene import SceneRecorder
    except ImportError as exc:  # pragma: no cover - the scene module ships with the package
        raise SensemakingError(f"--scene needs sensemaking.scene: {exc}") from exc
    source = args.detections or args.source
    return SceneRecorder(fps=config.fps, image_size=config.image_size,
                         metadata={"name": Path(source).stem, "source": str(source)})


def _optional_monitor(args: argparse.Namespace, config) -> Any:
    if not args.warnings:
        return None
    from sensemaking.reasoning.online import SituationMonitor

    return SituationMonitor(fps=config.fps, image_size=config.image_size)

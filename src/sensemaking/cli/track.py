"""``sensemaking track``: detections file in, tracks (same format) and explanations out."""

from __future__ import annotations

import argparse
import gc
import logging
import math
import os
import sys
from pathlib import Path
from typing import Any

# option ranges: the ranges of the parameters fps and image_size (a frame rate or an image side
# beyond these is a typo, not a camera)
from sensemaking.classes import check_kitti_class
from sensemaking.cli._progress import Progress
from sensemaking.config import MAX_FPS, MAX_IMAGE_SIDE, MIN_FPS, check_fps, parse_size
from sensemaking.errors import FrameLimitError, InputError, ProgramError
from sensemaking.io.text import refuse_nul

log = logging.getLogger(__name__)


def add_matching_options(p: argparse.ArgumentParser) -> None:
    """``--no-abduction`` and ``--max-solve-ms``, as ``track`` and ``batch`` take them."""
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


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "track",
        help="track a detections file (MOTChallenge or KITTI) and explain what happened",
        description="Online abductive tracking of a detections file. Writes tracks in the input's "
        "format and, optionally, the abduced events (JSON lines), the scene model and warnings.",
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument(
        "--detections",
        type=Path,
        nargs="+",
        action="extend",
        metavar="FILE",
        help="detections file (MOT det.txt or a KITTI file; a PointRCNN or KITTI label file may "
        "hold several classes; - reads stdin, and stdin or a pipe is read once, up to 4 GiB). "
        "Several files of one sequence, e.g. one per class "
        "(car/0001.txt pedestrian/0001.txt cyclist/0001.txt), are tracked jointly in one "
        "tracker: a track matches detections of its class only, may hide behind an object of "
        "any class, and ids are shared (repeatable)",
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
        "--output",
        required=True,
        type=Path,
        help="tracking results, in the input's format. A path with {class} writes one file per "
        "class, the benchmark's layout (e.g. runs/{class}/0001.txt -> runs/car/0001.txt, "
        "runs/pedestrian/0001.txt, ..., one per class of the input, empty if it has no "
        "track); without it every class goes to one file (KITTI's own results format; "
        "MOTChallenge results have no class column, so several classes need {class})",
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
    add_matching_options(p)
    p.add_argument(
        "--class",
        dest="class_name",
        default=None,
        help="class of the detections when the file does not say (e.g. car for KITTI RRC "
        "files, whose folder names it by default; with --format kitti a KITTI type); with "
        "several --detections files one class per file, comma-separated (car,pedestrian)",
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
        "--lookahead",
        type=float,
        default=None,
        metavar="SECONDS",
        help="fixed-lag abduction: decide each frame together with the frames of the next "
        "SECONDS (0..10; the lookahead_s parameter, default 0: online). Two crossing objects "
        "or one that reappears are told apart by what follows; outputs, events and warnings "
        "of a frame are then final SECONDS later (written when final, at their own frame)",
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
        help="override a parameter, e.g. --set max_hidden_s=2 or --set costs.resumes=200; a "
        "class's own score thresholds: --set class_confidence.pedestrian.min_confidence=0.5 "
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
        "--confidence",
        type=Path,
        default=None,
        metavar="FILE",
        help="rules (.lp) that replace the packaged confidence.lp: how sure each hiding is "
        "(the events' confidence)",
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
    from sensemaking.sandbox import DEFAULT_MAX_ATOMS, DEFAULT_MAX_MEMORY_MB, DEFAULT_TIMEOUT_S

    lim = p.add_argument_group(
        "limits of your own encodings (--rules, --encoding, --situations; as in ask)",
        "checked once before any frame: the program is grounded and solved without facts in a "
        "child process under all three; the atom limit holds for every frame too",
    )
    lim.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help=f"seconds for that check (default {DEFAULT_TIMEOUT_S:g})",
    )
    lim.add_argument(
        "--max-atoms",
        type=int,
        default=DEFAULT_MAX_ATOMS,
        metavar="N",
        help=f"ground atoms (default {DEFAULT_MAX_ATOMS})",
    )
    lim.add_argument(
        "--max-memory",
        type=int,
        default=DEFAULT_MAX_MEMORY_MB,
        metavar="MB",
        help=f"memory for that check, MB (default {DEFAULT_MAX_MEMORY_MB})",
    )
    p.add_argument(
        "--lanes",
        type=Path,
        default=None,
        metavar="FILE",
        help="lanes JSON for --warnings (pixels; format in docs/SITUATIONS.md and "
        "sensemaking.reasoning.context): BLOCKED_LANE is checked, warnings say the lane",
    )
    p.add_argument(
        "--segmentation",
        type=Path,
        default=None,
        metavar="PATH",
        help="label maps for --warnings: a folder of <frame>.npy/.png or one file (a standing "
        "camera); an object beside the road blocks no lane",
    )
    p.add_argument(
        "--labels",
        type=Path,
        default=None,
        metavar="FILE",
        help='label names of --segmentation, JSON {"0": "road", ...} (default: labels.json '
        "beside the maps, else the Cityscapes train ids)",
    )
    p.add_argument(
        "--profile",
        choices=("driving", "fixed"),
        default=None,
        help="scene profile for --warnings: driving (a camera on an ego vehicle) or fixed "
        "(a standing or handheld camera: no ego-vehicle warnings); default: the preset's "
        "(KITTI driving, MOT fixed)",
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
        "--pitch",
        choices=("level", "scene"),
        default=None,
        help="the camera's pitch over the road for --warnings: level (the horizon at the camera "
        "model's row) or scene (the horizon fitted to the boxes' bottoms and heights, "
        "docs/EGOMOTION.md); default: level",
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
    from sensemaking.ros.cli import add_options as add_ros_options

    add_ros_options(p)  # --topic, --classes, --passthrough, --live, ...: docs/ROS.md
    p.set_defaults(func=run)


def _check_options(args: argparse.Namespace) -> None:
    """Every option's unit and range, before any file is read."""
    from sensemaking.io.tables import class_id_of

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
    lookahead = getattr(args, "lookahead", None)
    if lookahead is not None and not (math.isfinite(lookahead) and 0 <= lookahead <= 10):
        raise InputError(f"--lookahead must be 0..10 seconds, got {lookahead!r}")
    for name in _class_names(args):
        if name is not None:
            check_kitti_class(args.format, class_id_of(name), f"--class {name}")


def _class_names(args: argparse.Namespace) -> list[str | None]:
    """``--class`` per detection file: one name for one file, a comma-separated list (one per
    file) for several, None for each when not given."""
    files = getattr(args, "detection_files", None) or [args.detections]
    if args.class_name is None:
        return [None] * len(files)
    if len(files) == 1:
        return [args.class_name]
    names = [n.strip() for n in args.class_name.split(",")]
    if len(names) != len(files):
        raise InputError(
            f"--class {args.class_name}: with {len(files)} --detections files, give one class "
            f"per file, comma-separated (got {len(names)})"
        )
    return names


def _check_input_files(args: argparse.Namespace) -> None:
    """Several detection files must be distinct files of one sequence (same sequence name)."""
    from sensemaking.io.stream import sequence_name

    files = args.detection_files
    seen: dict[str, Path] = {}
    for f in files:
        key = os.path.realpath(f)  # no error on a symlink loop: the reader names it
        if key in seen:
            raise InputError(f"detection file given twice (also as {seen[key]})", f)
        seen[key] = f
    names = {f: sequence_name(f, args.format) for f in files}
    first = files[0]
    for f in files[1:]:
        if names[f] != names[first]:
            raise InputError(
                f"detection files of different sequences: {names[f]!r} here, {names[first]!r} "
                f"in {first} (files tracked together must be one sequence's, named alike, "
                "e.g. car/0001.txt pedestrian/0001.txt)",
                f,
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

        for c in _seqinfo_candidates(args):
            if c.is_file():
                info = read_seqinfo(c)
                return check_fps(info.fps, "frameRate", c), _checked_size(info, c), info.length
        return None, None, None
    from sensemaking.io.kitti import read_kitti_seqinfo

    for c in _seqinfo_candidates(args):
        if c.is_file():
            found = read_kitti_seqinfo(c).get(det.stem)
            if found is not None:
                return check_fps(found.fps, "frame_rate", c), _checked_size(found, c), found.length
    if args.seqinfo:
        raise InputError(
            f"sequence {det.stem!r} (the detection file's name) is not in seqinfo", args.seqinfo
        )
    return None, None, None


def _seqinfo_candidates(args: argparse.Namespace) -> list[Path]:
    """Where the sequence's seqinfo is looked for, in order (``--seqinfo`` alone if given)."""
    if args.seqinfo:
        return [args.seqinfo]
    det = Path(args.detections)
    if args.format == "mot":
        return [det.parent.parent / "seqinfo.ini", det.parent / "seqinfo.ini"]
    return [p / "seqinfo.csv" for p in det.parents[:4]] + [
        p / "training" / "seqinfo.csv" for p in det.parents[:5]
    ]


def _classes_file(text: str | None) -> Path | None:
    """The file ``--classes`` names, as the class table reads it (a .json name or a file)."""
    if text is None:
        return None
    path = Path(text)
    return path if path.suffix.lower() == ".json" or path.is_file() else None


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
    if getattr(args, "lookahead", None) is not None:
        facts["lookahead_s"] = float(args.lookahead)
    if getattr(args, "fps", None) is not None:  # 0 and nan are errors, not "unset"
        fps = args.fps
    if fps is not None:
        facts["fps"] = float(fps)
    if size:
        facts["image_size"] = size
    return settings.load_config(getattr(args, "params_file", None), family, facts, args.params)


def _file_frames(args: argparse.Namespace, config: Any, length: int | None):
    """(frames as (frame, Detections) pairs, first frame, last frame, class ids) of the
    detection files, each checked whole before (so that a bad line stops the run before any
    work) and then read again frame by frame; several files merged frame by frame."""
    from sensemaking.io.stream import iter_detection_frames, merge_frames, scan_detections

    first = 1 if args.format == "mot" else 0
    seq_last = None if length is None else first + length - 1
    files, names = args.detection_files, _class_names(args)
    last: int | None = None
    classes: set[int] = set()
    owner: dict[int, Path] = {}  # class id -> the file that has it
    keys: set[str] | None = None
    for path, name in zip(files, names, strict=True):
        log.info("checking %s before tracking", path)
        summary = scan_detections(
            path, args.format, name, image_size=config.image_size, last_frame=seq_last
        )
        if summary.last is not None:
            last = summary.last if last is None else max(last, summary.last)
        hint = _file_class(path, name, args.format)
        mine = set(summary.classes) | ({hint} if hint is not None else set())
        for c in sorted(mine):
            if c in owner:
                from sensemaking.classes import class_name

                raise InputError(
                    f"class {class_name(c)} is also in {owner[c]}: give each class once "
                    "(tracked together, the same objects would be tracked twice)",
                    path,
                )
            owner[c] = path
            check_kitti_class(args.format, c, f"{path}: class {c}")
        classes |= mine
        if summary.detections:
            keys = set(summary.data_keys) if keys is None else keys & set(summary.data_keys)
    if seq_last is not None:
        last = seq_last if last is None else max(last, seq_last)
    streams = [
        iter_detection_frames(
            path, args.format, name, image_size=config.image_size, last_frame=seq_last
        )
        for path, name in zip(files, names, strict=True)
    ]
    frames = streams[0] if len(streams) == 1 else merge_frames(streams, keys)
    if len(classes) > 1:
        from sensemaking.classes import class_name

        log.info(
            "tracking %d classes in one tracker: %s",
            len(classes),
            ", ".join(class_name(c) for c in sorted(classes)),
        )
    return frames, first, last, sorted(classes)


def _file_class(path: Path, name: str | None, fmt: str) -> int | None:
    """The class a detection file is of even when it is empty: ``--class``, else (KITTI) its
    folder's name when that is a class name (``.../cyclist/0003.txt``); None if neither says."""
    from sensemaking.classes import class_id

    if name is not None:
        return class_id(name)
    if fmt != "kitti":
        return None
    try:
        return class_id(path.resolve().parent.name)
    except KeyError:
        return None


def _output_paths(args: argparse.Namespace, classes: list[int]) -> dict[int, Path] | None:
    """Class id -> results file when ``--output`` has the {class} field, else None (one file);
    refuses several classes in one MOTChallenge file (it has no class column)."""
    from sensemaking.sinks import CLASS_FIELD, class_paths

    if CLASS_FIELD in str(args.output):
        if not classes:
            raise InputError(
                f"--output has {CLASS_FIELD} but the input names no class (give --class)",
                args.output,
            )
        return class_paths(args.output, classes)
    if args.format == "mot" and len(classes) > 1:
        raise InputError(
            f"--output: MOTChallenge results have no class column, and the input has "
            f"{len(classes)} classes: put {CLASS_FIELD} in the path (e.g. runs/{CLASS_FIELD}/"
            f"{args.output.name}) for one file per class",
            args.output,
        )
    return None


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


def _scene_metadata(args: argparse.Namespace, source: Path) -> dict[str, Any]:
    """The scene's name and source (``sources`` too when several files were tracked)."""
    if len(args.detection_files) > 1:
        from sensemaking.io.stream import sequence_name

        return {
            "name": sequence_name(source, args.format),
            "source": str(source),
            "sources": [str(f) for f in args.detection_files],
        }
    return {"name": Path(source).stem, "source": str(source)}


def _situation_context(args: argparse.Namespace) -> tuple[Any, str]:
    """The scene context (lanes, segmentation) and the scene profile of --warnings, read and
    checked before any work."""
    from sensemaking import settings
    from sensemaking.reasoning.context import SceneContext

    needs = [
        name
        for name, given in (
            ("--situations", args.situations),
            ("--lanes", args.lanes),
            ("--segmentation", args.segmentation),
            ("--labels", args.labels),
            ("--profile", args.profile),
        )
        if given
    ]
    if needs and not args.warnings:
        raise InputError(f"{needs[0]} needs --warnings PATH (where the warnings go)")
    if args.labels is not None and args.segmentation is None:
        raise InputError("--labels names the labels of --segmentation: give --segmentation")
    family = "kitti" if args.format == "kitti" else "mot"
    profile = args.profile or settings.preset_profile(family)
    if not args.warnings:
        return None, profile
    context = SceneContext.load(
        lanes=args.lanes, segmentation=args.segmentation, labels=args.labels
    )
    return context, profile


def _world_motion(args: argparse.Namespace) -> dict[str, Any]:
    """``camera`` and ``ego_motion`` of the SituationMonitor from --camera / --ego-motion."""
    from sensemaking.io.egomotion import read_ego_motion
    from sensemaking.reasoning.egomotion import CameraModel, EgoMotionConfig

    camera = CameraModel.parse(args.camera) if args.camera else None
    if camera is None and args.format == "kitti":
        camera = CameraModel.kitti()
    if args.ego_motion is not None and camera is None:
        raise InputError("--ego-motion needs a camera model: --format kitti or --camera")
    ego = None if args.ego_motion is None else read_ego_motion(args.ego_motion)
    out: dict[str, Any] = {"camera": camera, "ego_motion": ego}
    pitch = getattr(args, "pitch", None)
    if pitch is not None:
        if camera is None:
            raise InputError("--pitch needs a camera model: --format kitti or --camera")
        out["ego_config"] = EgoMotionConfig(horizon_from_scene=pitch == "scene")
    return out


#: bytes read from stdin or a pipe given as --detections (spooled to a temporary file)
MAX_PIPED_BYTES = 4 * 2**30


def _spool(path: Path, folder: Path) -> Path:
    """``path`` itself if it is a regular file (or absent: the reader says so); else (``-``:
    stdin, a FIFO, a character device) its bytes, read once into a file in ``folder``, so that
    the checking pass and the tracking pass read the same bytes. At most ``MAX_PIPED_BYTES``."""
    import shutil
    import stat

    if str(path) == "-":
        src: Any = sys.stdin.buffer
        name = "stdin.txt"
    else:
        try:
            st = os.stat(path)
        except OSError:
            return path
        if stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode):
            return path
        src = open(path, "rb")  # noqa: SIM115 - closed below
        name = path.name or "stdin.txt"
    out = folder / name
    from sensemaking.ros import is_bag

    try:
        with open(out, "wb") as dst:
            shutil.copyfileobj(_Bounded(src, MAX_PIPED_BYTES, path, text=not is_bag(out)), dst)
    finally:
        if src is not sys.stdin.buffer:
            src.close()
    return out


class _Bounded:
    """A binary stream that refuses to give more than ``limit`` bytes, and (``text``) a NUL
    byte: no detections text has one (``/dev/zero`` is refused at once, not after 4 GiB)."""

    def __init__(self, raw: Any, limit: int, path: Path, text: bool = False):
        self.raw, self.left, self.path, self.text = raw, limit, path, text
        self.given = 0

    def read(self, n: int = -1) -> bytes:
        data = self.raw.read(min(n if n >= 0 else self.left + 1, self.left + 1))
        if self.text:
            refuse_nul(data, self.given, self.path)
        self.given += len(data)
        self.left -= len(data)
        if self.left < 0:
            raise InputError(
                f"more than {MAX_PIPED_BYTES} bytes from a pipe or stdin: give a file", self.path
            )
        return data


def run(args: argparse.Namespace) -> int:
    """Track (see :func:`_run`); detections from stdin (``-``) or a pipe are read once first."""
    import shutil
    import tempfile

    given = list(args.detections or [])
    if not any(str(f) == "-" or (f.exists() and not f.is_file()) for f in given):
        return _run(args)
    if sum(str(f) == "-" for f in given) > 1:
        raise InputError("--detections - (stdin) can be given once")
    folder = Path(tempfile.mkdtemp(prefix="sensemaking-stdin-"))
    try:
        args.detections = [_spool(f, folder) for f in given]
        return _run(args)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _run(args: argparse.Namespace) -> int:
    from sensemaking.lookahead import make_tracker
    from sensemaking.pipeline import Pipeline
    from sensemaking.sinks import (
        CLASS_FIELD,
        ClassTracksSink,
        EventsSink,
        SceneSink,
        TracksSink,
        WarningsSink,
        check_output_paths,
    )
    from sensemaking.tracker import Tracker

    # several files (one per class) are one input; args.detections is the first (seqinfo, name)
    args.detection_files = list(args.detections or [])
    args.detections = args.detection_files[0] if args.detection_files else None
    from sensemaking.ros import cli as ros

    bag = ros.open_input(args)  # a ROS 2 bag or MCAP file (sets --format's default)
    if args.detections is not None and args.format is None:
        raise InputError("--format mot|kitti is required with --detections")
    _check_options(args)
    per_class = CLASS_FIELD in str(args.output)
    if per_class and args.detections is None:
        raise InputError(
            f"--output with {CLASS_FIELD} needs --detections (the classes are read from the "
            "files before tracking)",
            args.output,
        )
    if args.detections is not None:
        _check_input_files(args)
    outputs = {
        "--output": None if per_class else args.output,
        "--events": args.events,
        "--scene": args.scene,
        "--warnings": args.warnings,
    }
    inputs = {
        **{f"--detections {d}": d for d in args.detection_files},
        "--source": args.source,
        "--detector": args.detector,
        "--seqinfo": args.seqinfo,
        "--encoding": args.encoding,
        "--confidence": args.confidence,
        **{f"--rules {r}": r for r in args.rules},
        **{f"--situations {r}": r for r in args.situations},
        "--lanes": args.lanes,
        "--segmentation": args.segmentation,
        "--labels": args.labels,
        "--ego-motion": args.ego_motion,
        "--params": getattr(args, "params_file", None),
        # a class table given as a file (else ID=NAME pairs)
        "--classes": _classes_file(getattr(args, "classes", None)),
    }
    if args.detections is not None:  # the seqinfo found beside the detections is an input too
        inputs.update({f"seqinfo {c}": c for c in _seqinfo_candidates(args) if os.path.isfile(c)})
    check_output_paths(outputs, inputs)
    context, profile = _situation_context(args)
    fps = size = length = None
    if args.detections is not None:
        fps, size, length = bag.info() if bag else _sequence_info(args)
    else:
        frames, size = _video_frames(args)
    if args.fps:
        fps = args.fps
    if args.image_size:
        size = parse_size(args.image_size)
    config = tracker_config(args, fps, size)
    first = last = None
    class_files: dict[int, Path] | None = None
    if args.detections is not None:
        frames, first, last, classes = (
            bag.frames(args, config) if bag else _file_frames(args, config, length)
        )
        class_files = None if ros.is_mcap_output(args.output) else _output_paths(args, classes)
        if class_files is not None:
            from sensemaking.classes import class_name

            check_output_paths(
                {
                    **{f"--output ({class_name(c)})": p for c, p in class_files.items()},
                    **outputs,
                },
                inputs,
            )
    from sensemaking.sandbox import Limits

    limits = Limits(args.timeout, args.max_atoms, args.max_memory)
    online = Tracker(
        config,
        encoding=args.encoding,
        rules=args.rules,
        limits=limits,
        confidence=args.confidence,
    )
    tracker = make_tracker(online)  # with lookahead_s > 0: frames decided k frames later
    recorder = monitor = None
    if args.ego_motion and not (args.warnings or args.scene):
        raise InputError("--ego-motion needs --warnings or --scene (it serves those)")
    if args.camera and not (args.warnings or args.scene or ros.wants_stories(args)):
        raise InputError(
            "--camera needs --warnings, --scene, --output RUN.mcap or --live (it serves those)"
        )
    if getattr(args, "pitch", None) and not args.warnings:
        raise InputError("--pitch needs --warnings (it serves those)")
    world = _world_motion(args)
    # the stories of --output RUN.mcap and --live, told at the end from the recorded scene
    stories = ros.run_stories(args, config, world["camera"])
    recorder = None if stories is None else stories.recorder
    if args.warnings:
        from sensemaking.reasoning.online import SituationMonitor

        monitor = SituationMonitor(
            context=context,
            fps=config.fps,
            image_size=config.image_size,
            extra_encodings=args.situations,
            limits=limits,
            profile=profile,
            **world,
        )
        if profile != "driving" and args.profile is None:  # silence would read as "all clear"
            log.warning(
                "--warnings: the %s preset's scene profile is %s (a standing camera, no ego "
                "vehicle): HIDDEN_ENTITY, REDUCED_VISIBILITY and SUDDEN_STOP are not checked; "
                "for a camera on a vehicle give --profile driving",
                "kitti" if args.format == "kitti" else "mot",
                profile,
            )
    source = args.detections or args.source
    total = 0 if last is None or first is None else last - first + 1
    with Progress(total, "tracking", enabled=not args.quiet) as progress:
        sinks: list[Any] = []
        try:
            if class_files is not None:
                sinks.append(
                    ClassTracksSink(class_files, args.format, write_hidden=args.write_hidden)
                )
            elif ros.is_mcap_output(args.output):
                sinks.append(ros.tracks_sink(args, config, bag, stories))
            else:
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
                            **_scene_metadata(args, source),
                            **(
                                {"camera": world["camera"].to_json()}
                                if world["camera"] is not None
                                else {}
                            ),
                        },
                    )
                )
            sinks.extend(ros.extra_sinks(args, config, bag, stories))
        except BaseException:
            from sensemaking.sinks import close_all

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
        # everything made so far lives as long as the run: the collector stops walking it (its
        # full collections over the libraries' own objects cost 30-50 ms frames; DESIGN-NOTES)
        gc.freeze()
        try:
            with pipe:
                summary = pipe.run(frames, first_frame=first, last_frame=last)
        except FrameLimitError as exc:
            files = getattr(args, "detection_files", None) or []
            if exc.path is None and len(files) == 1:  # the tracker's limits: name the input
                raise FrameLimitError(exc.problem, files[0]) from None
            raise
        except ProgramError as exc:  # the user's program on a frame's facts: name its files
            programs = [args.encoding, *args.rules, args.confidence]
            named = ", ".join(str(p) for p in programs if p is not None)
            if exc.path is None and named:
                raise ProgramError(exc.problem, named) from None
            raise
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
        finally:
            gc.unfreeze()  # a caller running several tracks in one process collects as before
    stats = tracker.stats
    if tracker is not online:  # every solve, the hypotheses' included, per frame of input
        stats = {**stats, "solve_ms": online.stats["solve_ms"]}
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
        where = ", ".join(str(p) for p in class_files.values()) if class_files else args.output
        print(
            f"{where}: {n_tracks} tracks over {summary.frames} frames, "
            f"{summary.events} events ({per_frame:.2f} ms/frame association"
            + (
                f", {stats['timed_out']} frames over the solve budget"
                if stats["timed_out"]
                else ""
            )
            + ")"
        )
    return 0

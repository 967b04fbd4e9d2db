"""``sensemaking render``: draw a scene onto its frames (mp4 / GIF / PNG folder)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path
from typing import Any

from sensemaking.errors import InputError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "render",
        help="draw a scene's tracks, hidden objects, events and warnings onto its frames",
        description="Draw a scene (from `sensemaking track --scene`) onto the sequence's images, "
        "a video, or a plain canvas of the image size. The output kind follows the path: "
        ".mp4/.mkv/.mov/.avi/.webm (ffmpeg), .gif, or a folder (one PNG per frame). "
        "Needs the 'viz' extra.",
    )
    p.add_argument("scene", type=Path, help="scene JSON written by `sensemaking track --scene`")
    p.add_argument(
        "--output", "-o", required=True, help="out.mp4, out.gif or a folder (ending in /) for PNGs"
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument(
        "--images",
        type=Path,
        help="folder of the sequence's images (sorted; numbered names = frames)",
    )
    src.add_argument(
        "--video", type=Path, help="video of the sequence (its first frame = the scene's first)"
    )
    p.add_argument(
        "--fps", type=float, default=None, help="output frame rate (default: the scene's)"
    )
    p.add_argument(
        "--scale",
        type=float,
        default=None,
        help="output px per image px "
        "(default: fit 640 px wide on a plain canvas, 1280 over images)",
    )
    p.add_argument("--frames", default=None, metavar="A:B", help="only frames A..B (inclusive)")
    p.add_argument(
        "--first-frame",
        type=int,
        default=None,
        help="frame number of the first image / video frame when file names do not say it",
    )
    add_warning_options(p)
    p.set_defaults(func=run)


def add_warning_options(p: argparse.ArgumentParser) -> None:
    w = p.add_mutually_exclusive_group()
    w.add_argument(
        "--warnings",
        type=Path,
        default=None,
        help="warnings JSON lines from `sensemaking track --warnings` "
        "(default: recomputed from the scene)",
    )
    w.add_argument("--no-warnings", action="store_true", help="show no warnings")


def warnings_arg(args: argparse.Namespace) -> Any:
    if getattr(args, "no_warnings", False):
        return None
    if getattr(args, "warnings", None) is not None:
        from sensemaking.viz._run import read_warnings

        return read_warnings(args.warnings)
    return "auto"


def parse_frames(text: str | None) -> range | None:
    if text is None:
        return None
    a, sep, b = text.partition(":")
    try:
        lo, hi = int(a), int(b if sep else a)
    except ValueError:
        raise InputError(f"--frames must look like 10:80, got {text!r}") from None
    if hi < lo:
        raise InputError(f"--frames: the last frame {hi} is before the first {lo}")
    return range(lo, hi + 1)


def run(args: argparse.Namespace) -> int:
    from sensemaking.cli._progress import Progress
    from sensemaking.viz._run import as_run
    from sensemaking.viz.render import render_scene

    if args.fps is not None and not (math.isfinite(args.fps) and 0 < args.fps <= 1000):
        raise InputError(
            f"--fps must be a frame rate in (0, 1000] frames per second, got {args.fps}"
        )
    if args.scale is not None and not 0 < args.scale <= 4:
        raise InputError(f"--scale must be in (0, 4], got {args.scale}")
    from sensemaking.sinks import check_output_paths
    from sensemaking.viz._media import output_kind

    inputs = {
        "SCENE": args.scene,
        "--images": args.images,
        "--video": args.video,
        "--warnings": args.warnings,
    }
    if output_kind(args.output) != "png":  # a folder of PNGs is a directory by design
        check_output_paths({"--output": args.output}, inputs)
    else:
        out = os.path.realpath(args.output)  # Path.resolve raises on a symlink loop
        for name, path in inputs.items():  # e.g. PNGs written over the --images folder's
            if path is not None and out == os.path.realpath(path):
                raise InputError(f"--output would write over the input {name}", args.output)
    scene = as_run(args.scene, warnings=warnings_arg(args))
    frames = parse_frames(args.frames)
    if frames is not None:  # only the scene's own frames: the range may not ask for more work
        known = scene.frames
        clipped = range(max(frames.start, known.start), min(frames.stop, known.stop))
        if not len(clipped):
            raise InputError(
                f"--frames {args.frames}: the scene has frames {known.start}.."
                f"{known.stop - 1}, none of them in that range"
            )
        frames = clipped
    total = len(frames) if frames is not None else len(scene.frames)
    with Progress(total, "rendering", enabled=not args.quiet) as progress:
        out = render_scene(
            scene,
            args.output,
            images=args.images,
            video=args.video,
            fps=args.fps,
            scale=args.scale,
            frames=frames,
            first_frame=args.first_frame,
            progress=progress.advance,
        )
    if not args.quiet:
        print(f"{out}: {total} frames")
    return 0

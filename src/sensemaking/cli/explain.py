"""``sensemaking explain SCENE [--track K]``: each track's story in sentences."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from sensemaking.errors import InputError
from sensemaking.fleet.cli import add_archive_options, scene_from_args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "explain",
        help="tell each track's story: appearances, occlusions, missing detections, endings",
        description="Explain a scene written by `sensemaking track --scene PATH`: "
        "one paragraph per track, in order of appearance, built from the abduced events.",
    )
    p.add_argument(
        "scene", type=Path, nargs="?", help="scene JSON (from `sensemaking track --scene`)"
    )
    p.add_argument(
        "--track", type=int, default=None, metavar="K", help="only the story of track K"
    )
    p.add_argument(
        "--why",
        action="store_true",
        help="with --track: after the story, each event's next-best explanations and their "
        "costs (as `sensemaking ask SCENE why K`)",
    )
    p.add_argument("--json", action="store_true", help='print {"track id": [sentences]} as JSON')
    add_archive_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from sensemaking.reasoning.questions import ask, explain, stories

    if args.why and args.track is None:
        raise InputError("--why needs --track K (the track whose events to weigh)")
    scene = scene_from_args(args)
    if args.track is not None:
        sentences = explain(scene, args.track)
        if args.why and args.track in scene:
            sentences += list(ask(scene, f"why {args.track}").lines)
        if args.json:
            print(json.dumps({str(args.track): sentences}, indent=2))
        else:
            print(" ".join(sentences))
        return 0 if args.track in scene else 1
    every = stories(scene)
    if args.json:
        print(json.dumps({str(k): v for k, v in every.items()}, indent=2))
        return 0
    if not every:
        print("this scene has no tracks")
    print("\n\n".join(" ".join(s) for s in every.values()))
    return 0

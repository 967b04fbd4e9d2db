"""``sensemaking ask SCENE QUERY``: question answering over a recorded scene (ASP)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from sensemaking.errors import InputError
from sensemaking.fleet.cli import add_archive_options, scene_from_args


def register(sub: argparse._SubParsersAction) -> None:
    from sensemaking.reasoning.questions import (
        DEFAULT_MAX_ATOMS,
        DEFAULT_MAX_MEMORY_MB,
        DEFAULT_TIMEOUT_S,
        NAMED_QUESTIONS,
    )

    named = "\n".join(f"  {usage}" for usage in NAMED_QUESTIONS.values())
    p = sub.add_parser(
        "ask",
        help="ask a question about a scene: a named question or ASP rules with #show",
        description="Answer a question about a scene written by "
        "`sensemaking track --scene PATH`.\n\n"
        "QUERY is a named question:\n" + named + "\n\n"
        "or ASP rules over the scene's predicates (track/2, box/6, state/3, occurs_at/2, "
        "holds_at/3, holds_during/4, in_corridor/2, ra/5, motion/3, ...; "
        "see reasoning/encodings/scene.lp), e.g.\n"
        "  sensemaking ask scene.json 'q(T) :- occurs_at(hides_behind(T,_),_). #show q/1.'\n"
        "Without #show the predicates the rules define are shown; a query of constraints only "
        "answers yes or no. A file name ending in .lp is read as the query.\n\n"
        "Queries may not use #include, #script, #external or other directives that reach "
        "outside the scene (allowed: rules, constraints, aggregates, #show, #minimize/#maximize); "
        "they run under --timeout, --max-atoms and --max-memory, and answer sets are printed as "
        "they are found.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    # one list: argparse cannot tell an optional SCENE from the question's first word when options
    # stand between them
    p.add_argument(
        "words",
        nargs="+",
        metavar="SCENE QUESTION",
        help="scene JSON (from `sensemaking track --scene`; left out with --archive), then "
        "a named question (e.g. `reappeared 7`) or ASP text or a .lp file",
    )
    p.add_argument(
        "--models",
        type=int,
        default=1,
        metavar="N",
        help="answer sets to show for ASP queries (0: all)",
    )
    p.add_argument(
        "--lanes",
        type=Path,
        help="lanes JSON (for `warnings`; format in sensemaking.reasoning.context)",
    )
    p.add_argument(
        "--segmentation",
        type=Path,
        help="label maps: a folder of <frame>.npy/.png or one file (for `warnings`)",
    )
    p.add_argument(
        "--labels", type=Path, help='label names JSON {"0": "road", ...} (default: Cityscapes ids)'
    )
    p.add_argument(
        "--corridor",
        help='ego corridor polygon, "x,y x,y x,y ..." (fractions of the image or pixels)',
    )
    p.add_argument("--json", action="store_true", help="print the answer as JSON")
    p.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help=f"seconds for grounding + solving an ASP query (default {DEFAULT_TIMEOUT_S:g})",
    )
    p.add_argument(
        "--max-atoms",
        type=int,
        default=DEFAULT_MAX_ATOMS,
        metavar="N",
        help=f"ground atoms an ASP query may produce (default {DEFAULT_MAX_ATOMS})",
    )
    p.add_argument(
        "--max-memory",
        type=int,
        default=DEFAULT_MAX_MEMORY_MB,
        metavar="MB",
        help=f"memory an ASP query may use, MB (default {DEFAULT_MAX_MEMORY_MB})",
    )
    add_archive_options(p)
    p.set_defaults(func=run, trailing_words="words")


def _query_text(parts: list[str]) -> str:
    if len(parts) == 1 and parts[0].endswith(".lp"):
        from sensemaking.io.text import read_input_text

        path = Path(parts[0])
        try:
            return read_input_text(path)
        except FileNotFoundError:
            raise InputError("query file not found", path) from None
        except IsADirectoryError:
            raise InputError("query file is a directory", path) from None
        except UnicodeDecodeError as exc:
            raise InputError(
                f"query file is not UTF-8 text ({exc.reason} at byte {exc.start})", path
            ) from None
        except OSError as exc:
            raise InputError(f"cannot read query file: {exc.strerror or exc}", path) from None
    return " ".join(parts)


def run(args: argparse.Namespace) -> int:
    from sensemaking.reasoning.context import SceneContext
    from sensemaking.reasoning.questions import ask

    if args.models < 0:
        raise InputError(f"--models must be >= 0, got {args.models}")
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise InputError(f"--timeout must be a positive number of seconds, got {args.timeout!r}")
    if args.max_atoms <= 0:
        raise InputError(f"--max-atoms must be a positive number of atoms, got {args.max_atoms}")
    if args.max_memory <= 0:
        raise InputError(f"--max-memory must be a positive number of MB, got {args.max_memory}")
    args.scene, args.query = (
        (None, args.words) if args.archive else (Path(args.words[0]), args.words[1:])
    )
    if not args.query:
        raise InputError(
            "give a question after the scene file (e.g. `sensemaking ask scene.json tracks`)"
        )
    scene = scene_from_args(args)
    query = _query_text(args.query)
    context = SceneContext.load(
        lanes=args.lanes,
        segmentation=args.segmentation,
        labels=args.labels,
        corridor=args.corridor,
    )
    printed: list[int] = []

    def stream(atoms: tuple[str, ...]) -> None:
        # every answer set but a lone first one is printed as it is found (a lone one may turn
        # out to be the whole answer, printed below in its plain form)
        printed.append(1)
        if len(printed) == 2:
            print(f"answer 1: {' '.join(first[0])}", flush=True)
        if len(printed) >= 2:
            print(f"answer {len(printed)}: {' '.join(atoms)}", flush=True)
        else:
            first.append(atoms)

    first: list[tuple[str, ...]] = []
    answer = ask(
        scene,
        query,
        context=context,
        max_models=args.models,
        timeout=args.timeout,
        max_atoms=args.max_atoms,
        max_memory_mb=args.max_memory,
        on_model=None if args.json or args.models == 1 else stream,
    )
    if args.json:
        print(json.dumps(answer.to_json(), indent=2))
    elif len(printed) < 2:
        for line in answer.lines:
            print(line)
        for note in answer.notes:
            print(f"note: {note}", file=sys.stderr)
    return 0 if answer.satisfiable else 1

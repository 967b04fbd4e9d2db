"""``sensemaking demo``: the built-in example (Figure 1 of the paper)."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="run the built-in example: a cyclist hidden behind a turning car",
        description="Tracks the paper's Figure 1 scene with abduction, prints the "
        "explanation as sentences and writes tracks, events, warnings, the scene model "
        "and (with the viz extra) a GIF and an HTML report.",
    )
    p.add_argument(
        "--output-dir", type=Path, default=Path("demo-output"), help="where the files go"
    )
    p.add_argument("--no-render", action="store_true", help="skip the GIF and the HTML report")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from sensemaking.demo import run_demo

    run_demo(args.output_dir, render=not args.no_render, echo=print)
    return 0

"""Command line: ``sensemaking <verb> ...``; each verb lives in ``sensemaking.cli.<verb>``.

Every verb module defines ``register(subparsers)`` which adds its parser and sets
``func(args) -> int``. Errors of bad input (:class:`~sensemaking.errors.SensemakingError`) become
one line on stderr and exit status 2; logging is configured here and only here.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from sensemaking import __version__
from sensemaking.errors import SensemakingError

#: verb modules, in the order ``--help`` lists them
VERBS = ("track", "demo", "evaluate", "benchmark", "calibrate", "ask", "explain", "render",
         "report", "batch", "query")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sensemaking",
        description="Online abductive visual sensemaking: tracking with explanations (ASP/clingo).",
    )
    parser.add_argument("--version", action="version", version=f"sensemaking {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    parser.add_argument("-q", "--quiet", action="store_true", help="only errors; no progress bar")
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    sub.required = True
    for verb in VERBS:
        try:
            module = importlib.import_module(f"sensemaking.cli.{verb}")
        except ModuleNotFoundError as exc:
            if exc.name == f"sensemaking.cli.{verb}":
                continue  # verb not built in this version
            raise
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.ERROR if args.quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(args.verbose, 2)]
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.func(args) or 0)
    except SensemakingError as exc:
        print(f"sensemaking {args.verb}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 1

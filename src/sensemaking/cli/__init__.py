"""Command line: ``sensemaking <verb> ...``; each verb lives in ``sensemaking.cli.<verb>``.

Every verb module defines ``register(subparsers)`` which adds its parser and sets
``func(args) -> int``. Errors of bad input (:class:`~sensemaking.errors.SensemakingError`) and of
the file system (a full disk, a permission) become one line on stderr and exit status 2; SIGTERM
is handled like Ctrl-C (the verb cleans up its temporary files; exit 130, or 143 for SIGTERM);
logging is configured here and only here. A bug still gets one line (exit 3; the traceback
with ``-vv``).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys
import threading
from collections.abc import Sequence
from typing import NoReturn

from sensemaking import __version__
from sensemaking.errors import SensemakingError

#: verb modules, in the order ``--help`` lists them
VERBS = (
    "track",
    "demo",
    "evaluate",
    "benchmark",
    "calibrate",
    "ask",
    "explain",
    "render",
    "report",
    "batch",
    "query",
)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (``prog: error: problem (see --help)``), exit 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="sensemaking",
        description="Online abductive visual sensemaking: "
        "tracking with explanations (ASP/clingo).",
    )
    parser.add_argument("--version", action="version", version=f"sensemaking {__version__}")
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)"
    )
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


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is, so that it unwinds like Ctrl-C."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated()


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    # a verb whose last positional takes several words (ask's question) gets those that follow
    # its options too; argparse leaves them over
    words = getattr(args, "trailing_words", None)
    if rest and words is not None and not any(w.startswith("-") for w in rest):
        getattr(args, words).extend(rest)
    elif rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    level = (
        logging.ERROR
        if args.quiet
        else (logging.WARNING, logging.INFO, logging.DEBUG)[min(args.verbose, 2)]
    )
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if main_thread else None
    try:
        return int(args.func(args) or 0)
    except SensemakingError as exc:
        print(f"sensemaking {args.verb}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except Terminated:
        print("terminated", file=sys.stderr)
        return _stopped(args, 143)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return _stopped(args, 130)
    except BrokenPipeError:
        return 1
    except OSError as exc:
        print(f"sensemaking {args.verb}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except MemoryError as exc:  # says nothing of itself
        print(
            f"sensemaking {args.verb}: error: out of memory {_one_line(exc)}".rstrip(),
            file=sys.stderr,
        )
        return 2
    except RecursionError:  # JSON (parameters, scenes, lanes) nested deeper than Python reads
        print(
            f"sensemaking {args.verb}: error: an input is nested too deeply to read",
            file=sys.stderr,
        )
        return 2
    except Exception as exc:  # noqa: BLE001 - a bug: one line, the traceback only when asked
        if type(exc).__name__ == "DecompressionBombError":  # Pillow: an image past its bound
            print(f"sensemaking {args.verb}: error: {_one_line(exc)}", file=sys.stderr)
            return 2
        logging.getLogger(__name__).debug("internal error", exc_info=True)
        print(
            f"sensemaking {args.verb}: internal error (a bug; -vv shows where): "
            f"{type(exc).__name__}: {_one_line(exc)}",
            file=sys.stderr,
        )
        return 3
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)


def _stopped(args: argparse.Namespace, code: int) -> int:
    """``code`` of an interrupted verb. A verb that leaves native work running when interrupted
    (``exits_at_once``: DuckDB, which looks for an interrupt only between its tasks) ends the
    process here: the interpreter's exit would wait for that work (seconds) or tear its threads
    down mid-task (an abort)."""
    if getattr(args, "exits_at_once", False):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text if len(text) <= 500 else text[:497] + "..."

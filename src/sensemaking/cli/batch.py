"""``sensemaking batch``: every sequence under data roots tracked on Ray into a Parquet archive."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from sensemaking.cli._progress import Progress
from sensemaking.cli.track import add_matching_options

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "batch",
        help="track every sequence under data folders (or a manifest) on Ray into a Parquet "
        "archive",
        description="Track every sequence found under the data roots (the KITTI / MOTChallenge "
        "layouts of ../shared/data, or a manifest CSV) with events, scene, warnings and, with "
        "ground truth, metrics; each sequence a Ray task. Results go to a Parquet archive "
        "(tables tracks, events, warnings, metrics, runs; docs/FLEET.md). Sequences archived "
        "before with the same inputs and parameters are skipped. Exit status 0 when every "
        "sequence succeeded, 1 when some failed (they are archived with their error). Needs the "
        "'fleet' extra.",
    )
    p.add_argument(
        "--data",
        metavar="ROOT",
        type=Path,
        action="append",
        required=True,
        help="a data folder (kitti/, mot17/, mot15/ inside) or a manifest .csv (repeatable)",
    )
    p.add_argument(
        "--archive",
        metavar="DIR",
        type=Path,
        required=True,
        help="the archive folder (created when missing)",
    )
    p.add_argument(
        "--workers",
        metavar="N",
        type=int,
        default=None,
        help="sequences run at once (default: every core; with --address: twice the "
        "cluster's CPUs in flight)",
    )
    p.add_argument(
        "--address",
        metavar="ADDR",
        default=None,
        help="join this Ray cluster (host:port or ray://host:port) instead of starting "
        "a local Ray",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="redo sequences already archived with the same inputs and parameters",
    )
    p.add_argument(
        "--label",
        default=None,
        help="a name for this parameter set in the runs table (for `query compare`)",
    )
    p.add_argument(
        "--only",
        metavar="PATTERN",
        action="append",
        default=[],
        help="only datasets or dataset/sequence matching this glob, e.g. 'kitti-rrc-*' "
        "or 'mot15/*' (repeatable)",
    )
    add_matching_options(p)
    p.add_argument(
        "--set",
        dest="params",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a TrackerConfig parameter for every sequence (repeatable)",
    )
    p.set_defaults(func=run)


def _selected(specs: list, patterns: list[str]) -> list:
    from fnmatch import fnmatchcase

    if not patterns:
        return specs
    return [
        s
        for s in specs
        if any(
            fnmatchcase(s.dataset, p) or fnmatchcase(f"{s.dataset}/{s.sequence}", p)
            for p in patterns
        )
    ]


def run(args: argparse.Namespace) -> int:
    from sensemaking.errors import InputError
    from sensemaking.fleet.batch import run_batch
    from sensemaking.fleet.run import RunParams
    from sensemaking.fleet.specs import find_sequences

    params = RunParams.from_strings(
        args.params, abduction=not args.no_abduction, max_solve_ms=args.max_solve_ms
    )
    specs, skipped = find_sequences(args.data)
    specs = _selected(specs, args.only)
    if not specs:
        raise InputError(f"no sequence matches --only {' '.join(args.only)}")
    for msg in skipped:
        log.warning("skipped: %s", msg)
    with Progress(len(specs), "sequences", enabled=not args.quiet) as bar:
        summary = run_batch(
            specs,
            args.archive,
            params,
            workers=args.workers,
            address=args.address,
            force=args.force,
            label=args.label,
            progress=lambda info: bar.advance(),
        )
    if not args.quiet:
        print(
            f"{args.archive}: {summary.archived} sequences archived, "
            f"{summary.skipped} already there, {len(summary.failed)} failed, "
            f"in {summary.seconds:.1f} s (run {summary.run_id})"
        )
    for dataset, sequence, error in summary.failed:
        print(f"failed: {dataset}/{sequence}: {error}", file=sys.stderr)
    return 0 if summary.ok else 1

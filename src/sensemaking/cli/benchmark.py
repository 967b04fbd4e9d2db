"""``sensemaking benchmark``: our tracker and its peers on KITTI / MOT17 / MOT15, one run, one
report."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

DEFAULT_DOCS = "docs/BENCHMARKS.md"
DEFAULT_PARAMS_DOC = "docs/PARAMETERS.md"
#: runs of every tracker on every sequence (the fastest counts)
DEFAULT_REPEAT = 3


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "benchmark",
        help="run ours and SORT / ByteTrack / OC-SORT on the benchmark data and write "
        "docs/BENCHMARKS.md",
        description="Track every benchmark found in the data folder with our tracker (with and "
        "without abduction) and the peers from the 'trackers' package, evaluate with the "
        "dataset's rules, and write a markdown report with a JSON twin. "
        "Needs the 'benchmark' extra for the peers.",
    )
    p.add_argument(
        "--data",
        metavar="PATH",
        default=None,
        help="data folder laid out like ../shared/data (default: ../shared/data)",
    )
    p.add_argument(
        "--output",
        metavar="DIR",
        default="out/benchmark",
        help="folder for the result files (default: out/benchmark)",
    )
    p.add_argument(
        "--only",
        metavar="NAMES",
        default=None,
        help="comma-separated benchmark names or patterns, e.g. kitti-rrc-car,mot17-* or kitti "
        "(default: all found)",
    )
    p.add_argument(
        "--trackers",
        metavar="NAMES",
        default=None,
        help="comma-separated subset of ours,ours-noabd,sort,bytetrack,ocsort (default: all)",
    )
    p.add_argument(
        "--docs",
        metavar="FILE",
        default=DEFAULT_DOCS,
        help=f"markdown report to write (default: {DEFAULT_DOCS}); '' to write none",
    )
    p.add_argument(
        "--json",
        metavar="FILE",
        default=None,
        help="JSON of all numbers (default: benchmarks.json beside the markdown)",
    )
    p.add_argument(
        "--jobs",
        metavar="N",
        type=int,
        default=1,
        help="benchmarks to run at once in worker processes (default 1; every tracker of a "
        "benchmark still runs in one process, so its time ratios stay comparable)",
    )
    p.add_argument(
        "--repeat",
        metavar="N",
        type=int,
        default=DEFAULT_REPEAT,
        help="runs of every tracker on every sequence; the per-frame times of the fastest count "
        f"(default {DEFAULT_REPEAT}: a busy machine's slow spells inflate single runs; "
        "results are the same)",
    )
    p.add_argument(
        "--no-crossval",
        action="store_true",
        help="skip the cross-validation of our parameters (leave one video out per family, "
        "about 5 minutes; the headline table of the report)",
    )
    p.add_argument(
        "--no-explanations",
        action="store_true",
        help="skip the explanation quality of ours (its event log and, on KITTI cars, the "
        "situation monitor's warnings, written under <output>/<benchmark>/ours-explanations/ "
        "during its tracking pass and judged against the ground truth: docs/EXPLANATIONS.md)",
    )
    p.add_argument(
        "--all-warnings",
        action="store_true",
        help="run the situation monitor and judge its warnings on every benchmark (default: "
        "the KITTI car benchmarks, whose 3D labels the warning targets need; the monitor "
        "costs more than the tracker on a crowded scene)",
    )
    p.add_argument(
        "--params-doc",
        metavar="FILE",
        default=DEFAULT_PARAMS_DOC,
        help=f"parameter reference to regenerate (default: {DEFAULT_PARAMS_DOC}); '' for none",
    )
    p.add_argument(
        "--list",
        action="store_true",
        help="list the benchmarks found and what is missing, then stop",
    )
    p.set_defaults(func=run)


def _command_line(args: argparse.Namespace) -> str:
    parts = ["sensemaking", "benchmark"]
    if args.data is not None:
        parts += ["--data", args.data]
    if args.output != "out/benchmark":
        parts += ["--output", args.output]
    if args.only:
        parts += ["--only", args.only]
    if args.trackers:
        parts += ["--trackers", args.trackers]
    if args.docs != DEFAULT_DOCS:
        parts += ["--docs", args.docs]
    if args.json:
        parts += ["--json", args.json]
    if args.jobs != 1:
        parts += ["--jobs", str(args.jobs)]
    if args.repeat != DEFAULT_REPEAT:
        parts += ["--repeat", str(args.repeat)]
    if args.no_crossval:
        parts += ["--no-crossval"]
    if args.no_explanations:
        parts += ["--no-explanations"]
    if args.all_warnings:
        parts += ["--all-warnings"]
    return shlex.join(parts)


def run(args: argparse.Namespace) -> int:
    from sensemaking.benchmark import datasets, report, runner
    from sensemaking.errors import InputError
    from sensemaking.sinks import check_output_paths

    if not 1 <= args.jobs <= 256:
        raise InputError(f"--jobs must be a number of processes in 1..256, got {args.jobs}")
    if not 1 <= args.repeat <= 1000:
        raise InputError(f"--repeat must be a number of timed runs in 1..1000, got {args.repeat}")
    if not args.list:
        check_output_paths({"--docs": args.docs or None, "--json": args.json})
        if Path(args.output).exists() and not Path(args.output).is_dir():
            raise InputError("--output must be a directory", args.output)
    only = args.only.split(",") if args.only else None
    if args.list:
        found = datasets.discover(args.data, only)
        print(f"data: {found.root}")
        for spec, sources in found.found:
            print(f"{spec.name:<28} {len(sources):>2} sequences  {spec.title}")
        for msg in found.all_skipped():
            print(f"skipped: {msg}")
        return 0

    quiet = bool(getattr(args, "quiet", False))

    def progress(msg: str) -> None:
        if not quiet:
            print(msg, file=sys.stderr, flush=True)

    summary = runner.run(
        data=args.data,
        output=args.output,
        only=only,
        trackers=args.trackers,
        progress=progress,
        command=_command_line(args),
        jobs=args.jobs,
        repeat=args.repeat,
        crossval=not args.no_crossval,
        explanations=not args.no_explanations,
        all_warnings=args.all_warnings,
    )
    if not quiet:  # the cross-validated headline first
        print(report.console_summary(summary), end="")
    if args.docs:
        md, js = report.write_report(summary, args.docs, args.json)
        progress(f"wrote {md} and {js}")
    if args.params_doc and summary.crossval:  # a run without cross-validation leaves it as it is
        progress(f"wrote {report.write_parameters(summary, args.params_doc)}")
    elif args.json:
        report.write_json(summary, args.json)
        progress(f"wrote {args.json}")
    if summary.errors:
        for err in summary.errors:
            print(f"sensemaking benchmark: failed: {err}", file=sys.stderr)
        return 1
    return 0

"""``sensemaking benchmark``: our tracker and its peers on KITTI / MOT17 / MOT15, one run: an
overview table on the console and every number in a JSON file.

The project's own pages (``docs/BENCHMARKS.md`` with its acceptance targets,
``docs/PARAMETERS.md``) are rendered from the same run by ``benchmarks/benchmark_report.py``,
which takes these options (:func:`add_options`, :func:`run_summary`) and ``--docs`` /
``--params-doc``; they are the project's, not the package's."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

#: runs of every tracker on every sequence (the fastest counts)
DEFAULT_REPEAT = 3


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "benchmark",
        help="run ours and SORT / ByteTrack / OC-SORT on the benchmark data",
        description="Track every benchmark found in the data folder with our tracker (with and "
        "without abduction) and the peers from the 'trackers' package, evaluate with the "
        "dataset's rules, print an overview and write every number as JSON. "
        "Needs the 'benchmark' extra for the peers.",
    )
    add_options(p)
    p.add_argument(
        "--json",
        metavar="FILE",
        default=None,
        help="JSON of all numbers (default: <output>/benchmarks.json)",
    )
    p.set_defaults(func=run)


def add_options(p: argparse.ArgumentParser) -> None:
    """The options of a benchmark run (shared with ``benchmarks/benchmark_report.py``)."""
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
        "--list",
        action="store_true",
        help="list the benchmarks found and what is missing, then stop",
    )


def command_line(
    args: argparse.Namespace, prog: tuple[str, ...] = ("sensemaking", "benchmark")
) -> str:
    """The command that repeats a run (for the report)."""
    parts = list(prog)
    if args.data is not None:
        parts += ["--data", args.data]
    if args.output != "out/benchmark":
        parts += ["--output", args.output]
    if args.only:
        parts += ["--only", args.only]
    if args.trackers:
        parts += ["--trackers", args.trackers]
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


def run_summary(
    args: argparse.Namespace, outputs: dict[str, str | None], prog: tuple[str, ...]
) -> Any:
    """Check the options and the ``outputs`` (option name -> path), run every benchmark and
    return the :class:`~sensemaking.benchmark.runner.RunSummary`; with ``--list``, print what
    was found and return None."""
    from sensemaking.benchmark import datasets, runner
    from sensemaking.errors import InputError
    from sensemaking.sinks import check_output_paths

    if not 1 <= args.jobs <= 256:
        raise InputError(f"--jobs must be a number of processes in 1..256, got {args.jobs}")
    if not 1 <= args.repeat <= 1000:
        raise InputError(f"--repeat must be a number of timed runs in 1..1000, got {args.repeat}")
    if not args.list:
        check_output_paths(outputs)
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
        return None
    return runner.run(
        data=args.data,
        output=args.output,
        only=only,
        trackers=args.trackers,
        progress=progress_printer(args),
        command=command_line(args, prog),
        jobs=args.jobs,
        repeat=args.repeat,
        crossval=not args.no_crossval,
        explanations=not args.no_explanations,
        all_warnings=args.all_warnings,
    )


def progress_printer(args: argparse.Namespace) -> Any:
    """Progress lines to stderr (none with ``--quiet``)."""
    quiet = bool(getattr(args, "quiet", False))

    def progress(msg: str) -> None:
        if not quiet:
            print(msg, file=sys.stderr, flush=True)

    return progress


def report_errors(summary: Any, prog: str) -> int:
    """Print the run's failures; the exit status (1 if any)."""
    for err in summary.errors:
        print(f"{prog}: failed: {err}", file=sys.stderr)
    return 1 if summary.errors else 0


def run(args: argparse.Namespace) -> int:
    from sensemaking.benchmark.summary import overview, write_json

    json_path = args.json or str(Path(args.output) / "benchmarks.json")
    summary = run_summary(args, {"--json": json_path}, ("sensemaking", "benchmark"))
    if summary is None:
        return 0
    if not getattr(args, "quiet", False):
        print("\n".join(["HOTA / MOTA / IDF1 / ID sw.", "", *overview(summary)]))
    progress_printer(args)(f"wrote {write_json(summary, json_path)}")
    return report_errors(summary, "sensemaking benchmark")

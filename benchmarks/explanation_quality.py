"""Explanation quality on every shared benchmark: are the tracker's events and warnings true?

The benchmark runner's own explanation pass (``sensemaking.benchmark.explanations``), with our
tracker alone and no cross-validation: ours (``TrackerConfig.for_dataset`` of the benchmark's
family, the runner's loading) with the situation monitor on every sequence of
``../shared/data``; every event and HIDDEN_ENTITY / SUDDEN_STOP / OVERTAKING warning judged
against the ground truth (``sensemaking.evaluation.explanations``, method in
docs/EXPLANATIONS.md). Prints the explanation-quality table per benchmark (markdown), as the
benchmark report has it.

    nice -n 10 .venv/bin/python benchmarks/explanation_quality.py [--only kitti-rrc-car] \\
        [--data ../shared/data] [--output out/explanations] [--json out.json] [--all-warnings] \\
        [--html out/explanations.html]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from sensemaking.benchmark.datasets import default_data_root
from sensemaking.benchmark.runner import run
from sensemaking.errors import SensemakingError
from sensemaking.evaluation.curves import explanations_html
from sensemaking.evaluation.explanations import confidence_text, explanation_table, spread_table
from sensemaking.io.atomic import atomic_write


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--data", type=Path, default=None, help="benchmark data (default ../shared/data)"
    )
    p.add_argument(
        "--only",
        action="append",
        default=None,
        metavar="NAME",
        help="benchmark name or glob (repeatable), e.g. kitti-rrc-car, mot17-*",
    )
    p.add_argument(
        "--output",
        type=Path,
        default=Path("out/explanations"),
        help="folder for the tracks, event and warning logs (default out/explanations)",
    )
    p.add_argument(
        "--all-warnings",
        action="store_true",
        help=(
            "run the situation monitor on every benchmark "
            "(default: KITTI cars only, as the runner)"
        ),
    )
    p.add_argument("--json", type=Path, default=None, help="write every verdict and summary here")
    p.add_argument(
        "--html",
        type=Path,
        default=None,
        help="write the precision-recall curves and the tables as one self-contained page",
    )
    args = p.parse_args(argv)
    root = args.data or default_data_root()
    if not Path(root).is_dir():
        print(f"{root}: no benchmark data", file=sys.stderr)
        return 2
    try:
        summary = run(
            data=root,
            output=args.output,
            only=args.only,
            trackers=["ours"],
            progress=lambda m: print(m, file=sys.stderr, flush=True),
            crossval=False,
            explanations=True,
            all_warnings=args.all_warnings,
        )
    except SensemakingError as exc:
        print(f"explanation_quality: error: {exc}", file=sys.stderr)
        return 2
    judged = {b.spec.name: b.explanations for b in summary.benchmarks if b.explanations}
    failed = [f"{name}: {ex.error}" for name, ex in judged.items() if ex.error]
    ok = {n: ex.results for n, ex in judged.items() if not ex.error}
    print(explanation_table(ok), end="")
    spread = spread_table(ok)
    if spread:
        print("\n" + spread, end="")
    curve = confidence_text(ok)
    if curve:
        print("\n" + curve, end="")
    if args.html is not None and ok:
        with atomic_write(args.html) as handle:
            handle.write(explanations_html(ok))
    seconds = sum(ex.seconds for ex in judged.values())
    print(f"\nexplanation part: {seconds:.1f} s of {summary.total_seconds:.1f} s", file=sys.stderr)
    if args.json is not None:
        doc = {
            name: {
                **ex.to_json(),
                "sequences": {
                    r.name: {
                        "events": [v.to_json() for v in r.events],
                        "warnings": [w.to_json() for w in r.warnings],
                    }
                    for r in ex.results
                },
            }
            for name, ex in judged.items()
        }
        with atomic_write(args.json) as handle:
            handle.write(json.dumps(doc, indent=1, default=str) + "\n")
    for line in failed:
        print(f"explanation_quality: failed: {line}", file=sys.stderr)
    return 1 if failed or summary.errors else 0


if __name__ == "__main__":
    raise SystemExit(main())

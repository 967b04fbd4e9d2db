"""Each tracking technique off and on, paired, per benchmark and per fold (issue 14, item 3).

For every technique (a switch of ``TrackerConfig``, :data:`TECHNIQUES`) our tracker (with
abduction, everything else at the family preset) runs with the switch off and on, on every
sequence of every benchmark of ``../shared/data`` (the runner's loading:
``sensemaking.benchmark.datasets``), and each sequence is scored as the cross-validation scores it
(visible tracks, result file written and read back, TrackEval's rules). Printed per family:

* per benchmark, HOTA / IDF1 / MOTA off and on (sequences combined as TrackEval combines them)
  and ms per frame inside ``Tracker.update`` off and on (the variants of a sequence run one after
  the other, so under the same load, each with the process's answer cache cleared; read from the
  cache, times are those of the run that made it);
* per fold -- a video, ``sensemaking.benchmark.crossval.fold_key``: a KITTI sequence number across
  its four benchmarks, a MOT17 sequence across its two, a MOT15 sequence -- the family-mean HOTA
  (mean over the benchmarks of that video's sequences) off, on and their difference, and how many
  folds improve / worsen;
* the verdict of the keep rule (:func:`verdict`): a technique is kept for a family only if it
  improves the family-mean HOTA on a clear majority of folds (at least twice as many folds improve
  as worsen, and more than half improve), the mean fold delta is positive, and the family-mean
  IDF1 over the benchmarks does not fall.

    nice -n 10 .venv/bin/python benchmarks/techniques.py [--family kitti|mot|all] \\
        [--techniques resume_reupdate,scene_shift,weak_confidence] [--data ../shared/data] \\
        [--cache /tmp/techniques-cache] [--json out.json] [--skip-off]

``--cache DIR`` keeps each (variant, benchmark, sequence) score in ``DIR`` (pickled), so that
families or variants run in separate processes and a later call prints them all; clear it after
any change of the code.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import pickle
import sys
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.abduction import components
from sensemaking.benchmark.crossval import family_of, fold_key
from sensemaking.benchmark.datasets import Benchmark, Sequence, default_data_root, iter_benchmarks
from sensemaking.benchmark.peers import OursAdapter
from sensemaking.benchmark.sequences import (
    ours_config,
    read_gt,
    read_results,
    rules_name,
    run_sequence,
    write_results,
)
from sensemaking.errors import SensemakingError
from sensemaking.evaluation import evaluate_sequence
from sensemaking.evaluation.report import SequenceMetrics
from sensemaking.settings import apply_settings, params_of

#: technique -> its setting (dotted parameter -> value when on; off is the opposite switch)
TECHNIQUES: dict[str, dict[str, Any]] = {
    "resume_reupdate": {"resume_reupdate": True},
    "scene_shift": {"scene_shift": True},
    # ByteTrack's own low threshold; weak_iou stays at its default, ByteTrack's 0.5
    "weak_confidence": {"weak_confidence": 0.1},
}
METRICS = ("HOTA", "IDF1", "MOTA")


@dataclass
class Scored:
    """One sequence tracked and scored: its metrics, seconds inside ``update`` and frames."""

    metrics: SequenceMetrics
    seconds: float
    frames: int


def off_settings(technique: str) -> dict[str, Any]:
    """The technique's settings turned off: a switch false, an optional threshold None."""
    return {k: False if isinstance(v, bool) else None for k, v in TECHNIQUES[technique].items()}


def _key(config: Any, bench: str, seq: str) -> str:
    """Cache key of a run: every parameter of its configuration, the benchmark, the sequence."""
    params = sorted(params_of(config).items())
    text = json.dumps(params, default=str) + f"|{bench}|{seq}"
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def score_sequence(
    bench: Benchmark,
    seq: Sequence,
    settings: Mapping[str, Any],
    out_dir: Path,
    cache: Path | None,
) -> Scored:
    """Track ``seq`` with the family preset changed by ``settings``; score the visible tracks."""
    spec = bench.spec
    base = ours_config(spec.family, fps=seq.info.fps, image_size=(seq.info.width, seq.info.height))
    config = apply_settings(base, dict(settings))
    key = _key(config, bench.spec.name, seq.name)
    if cache is not None and (cache / f"{key}.pkl").exists():
        with open(cache / f"{key}.pkl", "rb") as fh:
            return pickle.load(fh)  # noqa: S301 -- our own cache
    # every run starts cold, as `sensemaking track` on one sequence does: the answer cache and
    # slot Controls are shared by the process, and would otherwise speed up whichever variant of
    # a sequence runs second
    components.SHARED.clear()
    tracker = OursAdapter(name="ours", config=config, states=(0,))
    tracks, seconds = run_sequence(tracker, seq)
    path = out_dir / key / f"{seq.name}.txt"
    write_results(spec, path, tracks)
    metrics = evaluate_sequence(
        read_gt(spec, seq.gt_path),
        read_results(spec, path),
        rules_name(spec),
        n_frames=int(seq.info.length),
        name=seq.name,
        gt_path=seq.gt_path,
        tracks_path=path,
    )
    out = Scored(metrics, float(seconds.sum()), len(seconds))
    if cache is not None:
        cache.mkdir(parents=True, exist_ok=True)
        with open(cache / f"{key}.pkl", "wb") as fh:
            pickle.dump(out, fh)
    return out


def combined(scores: Mapping[str, Scored]) -> dict[str, float]:
    """HOTA / IDF1 / MOTA of sequences combined (TrackEval's combination) and ms per frame."""
    m = SequenceMetrics.combine([s.metrics for s in scores.values()])
    out = {k: float(m[k]) for k in METRICS}
    out["ms"] = (
        1000.0 * sum(s.seconds for s in scores.values()) / sum(s.frames for s in scores.values())
    )
    return out


def fold_means(
    benches: list[Benchmark], scores: Mapping[str, Mapping[str, Scored]], metric: str = "HOTA"
) -> dict[str, float]:
    """fold -> mean over the family's benchmarks and the fold's sequences of ``metric``
    (``scores``: benchmark -> sequence -> Scored), as the cross-validation scores a video."""
    per: dict[str, list[float]] = {}
    for b in benches:
        for s in b.sequences:
            per.setdefault(fold_key(b.spec, s.name), []).append(
                float(scores[b.spec.name][s.name].metrics[metric])
            )
    return {f: float(np.mean(v)) for f, v in sorted(per.items())}


def verdict(deltas: Mapping[str, float], idf1_off: float, idf1_on: float) -> tuple[bool, str]:
    """The keep rule: (kept, why). ``deltas``: fold -> on - off family-mean HOTA;
    ``idf1_*``: mean over the family's benchmarks of their combined IDF1."""
    d = np.array(list(deltas.values()))
    up, down = int((d > 1e-9).sum()), int((d < -1e-9).sum())
    clear = up >= 2 * down and up > len(d) / 2
    mean = float(d.mean())
    kept = clear and mean > 0 and idf1_on >= idf1_off
    why = (
        f"{up} of {len(d)} folds improve, {down} worsen"
        f" ({'a clear majority' if clear else 'no clear majority'}), mean delta "
        f"{100 * mean:+.3f} HOTA, family-mean IDF1 {100 * idf1_off:.2f} -> {100 * idf1_on:.2f}"
    )
    return kept, why


def report_family(
    family: str,
    benches: list[Benchmark],
    technique: str,
    off: Mapping[str, Mapping[str, Scored]],
    on: Mapping[str, Mapping[str, Scored]],
    say: Callable[[str], None],
) -> dict[str, Any]:
    """Print the technique's tables for one family; return them as data."""
    say(f"\n### {technique} -- family {family}\n")
    say(
        "| benchmark | HOTA off | HOTA on | IDF1 off | IDF1 on | MOTA off | MOTA on "
        "| ms/frame off | ms/frame on |"
    )
    say("|---|---|---|---|---|---|---|---|---|")
    rows = {}
    for b in benches:
        a, c = combined(off[b.spec.name]), combined(on[b.spec.name])
        rows[b.spec.name] = {"off": a, "on": c}
        say(
            f"| {b.spec.name} | {100 * a['HOTA']:.2f} | {100 * c['HOTA']:.2f} "
            f"| {100 * a['IDF1']:.2f} | {100 * c['IDF1']:.2f} "
            f"| {100 * a['MOTA']:.2f} | {100 * c['MOTA']:.2f} "
            f"| {a['ms']:.2f} | {c['ms']:.2f} |"
        )
    f_off, f_on = fold_means(benches, off), fold_means(benches, on)
    deltas = {f: f_on[f] - f_off[f] for f in f_off}
    say("\n| fold | family-mean HOTA off | on | delta |")
    say("|---|---|---|---|")
    for f in f_off:
        say(f"| {f} | {100 * f_off[f]:.2f} | {100 * f_on[f]:.2f} | {100 * deltas[f]:+.2f} |")
    idf1_off = float(np.mean([r["off"]["IDF1"] for r in rows.values()]))
    idf1_on = float(np.mean([r["on"]["IDF1"] for r in rows.values()]))
    kept, why = verdict(deltas, idf1_off, idf1_on)
    say(f"\n**{technique}, {family}: {'KEEP (on)' if kept else 'leave off'}** -- {why}")
    return {"benchmarks": rows, "folds_off": f_off, "folds_on": f_on, "kept": kept, "why": why}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--family", choices=("kitti", "mot", "all"), default="all")
    ap.add_argument("--techniques", default=",".join(TECHNIQUES))
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--cache", type=Path, default=None)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument(
        "--skip-off",
        action="store_true",
        help="run only the techniques on (the off runs come from --cache, e.g. another process)",
    )
    args = ap.parse_args(argv)
    techniques = [t.strip() for t in args.techniques.split(",") if t.strip()]
    unknown = [t for t in techniques if t not in TECHNIQUES]
    if unknown:
        print(f"unknown technique(s) {unknown}; known: {list(TECHNIQUES)}", file=sys.stderr)
        return 2

    def say(msg: str) -> None:
        print(msg, flush=True)

    def note(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    try:
        benches = list(iter_benchmarks(args.data or default_data_root()))
    except SensemakingError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    families: dict[str, list[Benchmark]] = {}
    for b in benches:
        families.setdefault(family_of(b.spec), []).append(b)
    wanted = list(families) if args.family == "all" else [args.family]
    out: dict[str, Any] = {}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="techniques-") as tmp:
        for family in wanted:
            fam = families.get(family, [])
            if not fam:
                note(f"no benchmark of family {family} under the data folder")
                continue
            # all techniques off: every variant differs from this baseline in one switch only
            baseline: dict[str, Any] = {}
            for t in techniques:
                baseline.update(off_settings(t))
            variants = {"off": baseline}
            variants.update({t: {**baseline, **TECHNIQUES[t]} for t in techniques})
            if args.skip_off:
                del variants["off"]
            runs: dict[str, dict[str, dict[str, Scored]]] = {
                name: {b.spec.name: {} for b in fam} for name in variants
            }
            # every variant of a sequence one after the other: their times are measured under
            # the same load of the machine
            for b in fam:
                for s in b.sequences:
                    for name, settings in variants.items():
                        t0 = time.perf_counter()
                        scored = score_sequence(b, s, settings, Path(tmp), args.cache)
                        runs[name][b.spec.name][s.name] = scored
                        hota, took = 100 * scored.metrics["HOTA"], time.perf_counter() - t0
                        where = f"[{family} {name}] {b.spec.name} {s.name}"
                        note(f"{where}: HOTA {hota:.2f} ({took:.1f} s)")
            if "off" not in runs:
                note(f"[{family}] techniques on done; run again without --skip-off to print")
                continue
            out[family] = {
                t: report_family(family, fam, t, runs["off"], runs[t], say) for t in techniques
            }
    say(f"\n(wall time {time.perf_counter() - start:.0f} s)")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())

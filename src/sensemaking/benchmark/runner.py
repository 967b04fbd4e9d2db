"""Run every tracker on every benchmark, write its results, evaluate them, collect the numbers.

One run: for each benchmark found by :mod:`~sensemaking.benchmark.datasets`, each tracker of
:data:`~sensemaking.benchmark.peers.TRACKER_NAMES` (ours with and without abduction, SORT,
ByteTrack, OC-SORT) tracks every sequence frame by frame; only the tracker's ``update`` call is
timed (``time.perf_counter``), never reading or writing files. Results are written in the
dataset's own format under ``output/<benchmark>/<tracker>[-<variant>]/<sequence>.txt`` and scored
with :func:`sensemaking.evaluation.evaluate` under the benchmark's rules (KITTI also in the old
devkit's ID-switch mode).

Each peer runs twice: with its own defaults (``default``) and with a score pre-filter at the
threshold our tracker needs to start a track (``prefilter``). Our tracker runs once per benchmark
and writes two results from that pass: the tracks matched to a detection in each frame
(``visible``), and those plus the hidden / missing tracks at their predicted boxes
(``predicted``). For every tracker the report shows the better variant by HOTA and says which one
it is; every variant is in the JSON. boxmot's peers run once, at their defaults only.

Our tracker's pass also writes its event log and, on KITTI cars, feeds the situation monitor and
writes its warnings (outside the timed ``update`` call); after the passes they are judged
against the ground truth (:mod:`~sensemaking.benchmark.explanations`): the report's
explanation-quality table.

After the tracking passes, our parameters are cross-validated within each family
(:mod:`~sensemaking.benchmark.crossval`): the report's headline.
"""

from __future__ import annotations

import logging
import platform
import time
from collections.abc import Callable, Iterable
from collections.abc import Sequence as SequenceABC
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sensemaking.benchmark.crossval import cross_validate, family_of, fold_key
from sensemaking.benchmark.datasets import (
    Benchmark,
    BenchmarkSpec,
    Sequence,
    discover,
    load_benchmark,
)
from sensemaking.benchmark.explanations import (
    BenchmarkExplanations,
    SequenceCapture,
    judge_all,
    log_paths,
    monitors_warnings,
)
from sensemaking.benchmark.peers import (
    BOXMOT_PEERS,
    OURS,
    PEERS,
    TRACKER_NAMES,
    TRACKERS_PEERS,
    FrameTracker,
    OursAdapter,
    make_peer,
    peer_defaults,
)
from sensemaking.benchmark.sequences import (
    frames_of,
    ours_config,
    ours_score_threshold,
    read_gt,
    read_results,
    rules_name,
    run_sequence,
    write_results,
)
from sensemaking.detections import Detections
from sensemaking.errors import InputError, MissingExtraError
from sensemaking.evaluation.report import PER_SEQUENCE_FIELDS

if TYPE_CHECKING:  # pragma: no cover
    pass

__all__ = [
    "TrackerRun",
    "BenchmarkRun",
    "RunSummary",
    "ours_config",
    "ours_score_threshold",
    "parse_trackers",
    "run_sequence",
    "run_benchmark",
    "run",
    "machine_info",
    "SELECT_BY",
]

log = logging.getLogger(__name__)

#: the metric that picks a peer's better variant (higher is better)
SELECT_BY = "HOTA"
Progress = Callable[[str], None]


# -- results --------------------------------------------------------------------------------------
@dataclass
class TrackerRun:
    """One tracker (in one variant) on one benchmark.

    Attributes:
        tracker: ``ours``, ``ours-noabd``, ``sort``, ``bytetrack`` or ``ocsort``.
        variant: ``config`` (ours), ``default`` or ``prefilter`` (peers).
        min_score: the pre-filter threshold, or None.
        frames: frames tracked (all sequences).
        update_seconds: total seconds inside the tracker's update calls.
        result_dir: where the result files are.
        metrics: combined metrics over all sequences (TrackEval names; fractions, not %).
        per_sequence: metrics per sequence.
        legacy: combined metrics in the old KITTI devkit's ID-switch mode (KITTI only).
        error: why the run failed, or None.
    """

    tracker: str
    variant: str
    min_score: float | None = None
    frames: int = 0
    update_seconds: float = 0.0
    result_dir: Path | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    per_sequence: dict[str, dict[str, float]] = field(default_factory=dict)
    legacy: dict[str, float] | None = None
    error: str | None = None

    timing: dict[str, float] = field(default_factory=dict)

    @property
    def ms_per_frame(self) -> float:
        """Mean milliseconds per frame inside the tracker's update call."""
        return 1000.0 * self.update_seconds / self.frames if self.frames else float("nan")

    def set_times(self, seconds: np.ndarray) -> None:
        """Record the per-frame update times (seconds): total, and median / p95 / max in ms."""
        self.frames = int(seconds.size)
        self.update_seconds = float(seconds.sum())
        if seconds.size:
            ms = 1000.0 * seconds
            self.timing = {
                "median_ms": float(np.median(ms)),
                "p95_ms": float(np.percentile(ms, 95)),
                "max_ms": float(ms.max()),
            }

    def to_json(self) -> dict[str, Any]:
        return {
            "tracker": self.tracker,
            "variant": self.variant,
            "min_score": self.min_score,
            "frames": self.frames,
            "update_seconds": self.update_seconds,
            "ms_per_frame": None if not self.frames else self.ms_per_frame,
            **self.timing,
            "result_dir": None if self.result_dir is None else str(self.result_dir),
            "metrics": self.metrics,
            "legacy": self.legacy,
            "per_sequence": self.per_sequence,
            "error": self.error,
        }


@dataclass
class BenchmarkRun:
    """Every tracker on one benchmark."""

    spec: BenchmarkSpec
    sequences: list[str]
    frames: int
    skipped: list[str]
    runs: dict[str, list[TrackerRun]] = field(default_factory=dict)
    ours_config: dict[str, Any] | None = None
    #: explanation quality of ours with abduction (None: not measured)
    explanations: BenchmarkExplanations | None = None

    def chosen(self, tracker: str) -> TrackerRun | None:
        """The run reported for ``tracker``: the better variant by :data:`SELECT_BY`."""
        runs = [r for r in self.runs.get(tracker, []) if r.error is None and r.metrics]
        if not runs:
            failed = self.runs.get(tracker, [])
            return failed[0] if failed else None

        def key(r: TrackerRun) -> tuple[float, float, int]:
            return (
                float(r.metrics.get(SELECT_BY, -np.inf)),
                float(r.metrics.get("MOTA", -np.inf)),
                int(r.variant in ("default", "visible")),
            )

        return max(runs, key=key)

    def time_ratio(self, tracker: str) -> float | None:
        """Per-frame time of ``tracker`` divided by ours (with abduction) in this run."""
        mine, ours = self.chosen(tracker), self.chosen("ours")
        if (
            mine is None
            or ours is None
            or not mine.frames
            or not ours.frames
            or ours.update_seconds <= 0
        ):
            return None
        return mine.ms_per_frame / ours.ms_per_frame

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "name": self.spec.name,
            "title": self.spec.title,
            "family": self.spec.family,
            "rules": self.spec.rules,
            "class": self.spec.class_name,
            "sequences": self.sequences,
            "frames": self.frames,
            "skipped": self.skipped,
            "ours_config": self.ours_config,
            "trackers": {},
            "explanations": None if self.explanations is None else self.explanations.to_json(),
        }
        for name, runs in self.runs.items():
            chosen = self.chosen(name)
            out["trackers"][name] = {
                "chosen_variant": None if chosen is None else chosen.variant,
                "time_ratio_to_ours": self.time_ratio(name),
                "variants": {r.variant: r.to_json() for r in runs},
            }
        return out


@dataclass
class RunSummary:
    """The whole run: what was measured, where, how long it took and how to repeat it."""

    benchmarks: list[BenchmarkRun]
    skipped: list[str]
    trackers: list[str]
    data_root: str
    output_dir: str
    command: str
    started: str
    total_seconds: float = 0.0
    machine: dict[str, Any] = field(default_factory=dict)
    peer_defaults: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: leave-one-video-out cross-validation of our parameters, one per family (may be empty)
    crossval: list[Any] = field(default_factory=list)

    @property
    def errors(self) -> list[str]:
        return [
            f"{b.spec.name}/{r.tracker}/{r.variant}: {r.error}"
            for b in self.benchmarks
            for runs in b.runs.values()
            for r in runs
            if r.error
        ]

    def to_json(self) -> dict[str, Any]:
        return {
            "started": self.started,
            "total_seconds": self.total_seconds,
            "command": self.command,
            "data_root": self.data_root,
            "output_dir": self.output_dir,
            "trackers": self.trackers,
            "select_by": SELECT_BY,
            "machine": self.machine,
            "peer_defaults": self.peer_defaults,
            "skipped": self.skipped,
            "errors": self.errors,
            "benchmarks": [b.to_json() for b in self.benchmarks],
            "crossval": [cv.to_json() for cv in self.crossval],
        }


# -- machine --------------------------------------------------------------------------------------
def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _load_average() -> list[float] | None:
    import os

    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):  # pragma: no cover - not on every platform
        return None


def machine_info() -> dict[str, Any]:
    """CPU, cores, OS, Python and the versions of the packages that matter for the numbers."""
    import os
    from importlib import metadata

    versions: dict[str, str | None] = {}
    for pkg in (
        "sensemaking",
        "numpy",
        "scipy",
        "clingo",
        "trackers",
        "supervision",
        "boxmot",
        "torch",
    ):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    return {
        "load_average_start": _load_average(),
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "packages": versions,
    }


# -- tracking -------------------------------------------------------------------------------------
def parse_trackers(names: Iterable[str] | str | None) -> list[str]:
    """Tracker keys in report order; accepts a comma-separated string. Raises InputError."""
    if names is None:
        return list(TRACKER_NAMES)
    if isinstance(names, str):
        names = names.split(",")
    wanted = [n.strip().lower() for n in names if n and n.strip()]
    aliases = {"ours-abd": "ours", "oc-sort": "ocsort", "byte": "bytetrack", "noabd": "ours-noabd"}
    wanted = [aliases.get(n, n) for n in wanted]
    unknown = [n for n in wanted if n not in TRACKER_NAMES]
    if unknown:
        raise InputError(
            f"unknown tracker(s) {', '.join(unknown)}; known: {', '.join(TRACKER_NAMES)}"
        )
    return [n for n in TRACKER_NAMES if n in wanted] or list(TRACKER_NAMES)


def _make_tracker(
    name: str, variant: str, spec: BenchmarkSpec, seq: Sequence, min_score: float | None
) -> FrameTracker:
    if name in OURS:
        config = ours_config(
            spec.family,
            abduction=(name == "ours"),
            fps=seq.info.fps,
            image_size=(seq.info.width, seq.info.height),
        )
        return OursAdapter(name=name, config=config, states=(0, 1, 2))
    return make_peer(
        name,
        frame_rate=float(seq.info.fps),
        min_score=min_score if variant == "prefilter" else None,
        image_size=(int(seq.info.width), int(seq.info.height)),
    )


#: our tracker's two outputs from one tracking pass: variant -> track states written
OURS_OUTPUTS: dict[str, tuple[int, ...]] = {"visible": (0,), "predicted": (0, 1, 2)}


def _passes(name: str, threshold: float | None) -> list[tuple[str, float | None]]:
    """Tracking passes of a tracker: (pass name, pre-filter threshold)."""
    if name in OURS:
        return [("config", None)]
    out: list[tuple[str, float | None]] = [("default", None)]
    if name in BOXMOT_PEERS:  # boxmot's own defaults only (the protocol)
        return out
    if threshold is not None:
        out.append(("prefilter", threshold))
    return out


def _outputs(name: str, pass_name: str, tracks: Detections) -> dict[str, Detections]:
    """The result variants written from one pass: peers one; ours two (visible tracks only, and
    visible plus hidden / missing tracks at their predicted boxes)."""
    if name not in OURS:
        return {pass_name: tracks}
    state = tracks.data.get("state")
    if state is None or len(tracks) == 0:
        return {v: tracks for v in OURS_OUTPUTS}
    state = np.asarray(state, dtype=np.int64)
    return {v: tracks[np.isin(state, states)] for v, states in OURS_OUTPUTS.items()}


def _label(name: str, variant: str) -> str:
    return name if variant in ("default", "visible") else f"{name}-{variant}"


# -- evaluation -----------------------------------------------------------------------------------
def _evaluate(
    bench: Benchmark,
    result_dir: Path,
    gt: dict[str, Detections],
    modes: SequenceABC[str] = ("trackeval",),
) -> dict[str, tuple[dict[str, float], dict[str, Any]]]:
    """Score the result files in ``result_dir`` (read back from disk) under the benchmark's rules.

    Returns:
        idsw_mode -> (combined metrics, per-sequence metrics)
    """
    from sensemaking.evaluation import SequenceInput, evaluate

    spec = bench.spec
    inputs = {}
    for s in bench.sequences:
        path = result_dir / f"{s.name}.txt"
        inputs[s.name] = SequenceInput(
            gt=gt[s.name],
            tracks=read_results(spec, path),
            n_frames=int(s.info.length),
            gt_path=s.gt_path,
            tracks_path=path,
        )
    out = {}
    for mode in modes:
        report = evaluate(inputs, rules_name(spec), idsw_mode=mode)
        per_seq = {
            s.name: _metrics_dict(report[s.name], PER_SEQUENCE_FIELDS) for s in bench.sequences
        }
        out[mode] = (_metrics_dict(report.combined()), per_seq)
    occ = _occlusion(bench, inputs)
    if occ is not None:
        for combined, per_seq in out.values():
            combined.update(occ[0])
            for name, fields in occ[1].items():
                per_seq[name].update(fields)
    return out


def _occlusion(
    bench: Benchmark, inputs: dict[str, Any]
) -> tuple[dict[str, float], dict[str, dict[str, float]]] | None:
    """Identity through occlusion (``sensemaking.evaluation.occlusion``) as metric fields
    ``OCC_kept``, ``OCC_switched``, ``OCC_lost``, ``OCC_not_tracked`` (counts) and
    ``OCC_kept_share`` (kept of tracked-before, a fraction): pooled, and per sequence. None
    where the ground truth has no visibility (MOT15)."""
    from sensemaking.evaluation.occlusion import OcclusionCounts, benchmark_occlusion

    spec = bench.spec
    if spec.rules == "mot15":
        return None
    fps = {s.name: float(s.info.fps) for s in bench.sequences}
    fmt = "kitti" if spec.rules == "kitti" else "mot"
    (per_seq,) = benchmark_occlusion(inputs, fmt, (spec.class_name or "car",), fps).values()

    def fields(c: OcclusionCounts) -> dict[str, float]:
        f: dict[str, float] = {
            "OCC_kept": c.counts["kept"],
            "OCC_switched": c.counts["switched"],
            "OCC_lost": c.counts["lost"],
            "OCC_not_tracked": c.counts["not tracked before"],
        }
        if c.tracked_before:
            f["OCC_kept_share"] = c.kept_share
        return f

    counts = {n: OcclusionCounts.of(e) for n, e in per_seq.items()}
    return fields(sum(counts.values(), OcclusionCounts())), {
        n: fields(c) for n, c in counts.items()
    }


def _metrics_dict(m: Any, fields: SequenceABC[str] | None = None) -> dict[str, float]:
    out: dict[str, float] = {}
    for k in m if fields is None else [f for f in fields if f in m]:
        v = m[k]
        if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool):
            out[k] = int(v) if isinstance(v, (int, np.integer)) else float(v)
    return out


# -- the run --------------------------------------------------------------------------------------
def run_benchmark(
    bench: Benchmark,
    trackers: SequenceABC[str],
    output_dir: Path,
    progress: Progress | None = None,
    repeat: int = 1,
    explanations: bool = True,
    all_warnings: bool = False,
) -> BenchmarkRun:
    """Every tracker (and variant) on every sequence of ``bench``; results written and evaluated.
    Each tracker runs each sequence ``repeat`` times; the per-frame times of the fastest run
    count (a shared machine's slow spells inflate single runs), the results are those of the
    first (every run gives the same). With ``explanations`` and ``ours`` among the trackers,
    the first run of ours also writes its event log and (on KITTI cars, or everywhere with
    ``all_warnings``: :func:`~sensemaking.benchmark.explanations.monitors_warnings`) runs the
    situation monitor, judged after the passes (``result.explanations``)."""
    say = progress or (lambda msg: None)
    spec = bench.spec
    result = BenchmarkRun(
        spec, [s.name for s in bench.sequences], bench.n_frames, list(bench.skipped)
    )
    frames_per_seq = {s.name: frames_of(s) for s in bench.sequences}
    gt = {s.name: read_gt(spec, s.gt_path) for s in bench.sequences}
    modes = ("trackeval", "kitti_legacy") if spec.rules == "kitti" else ("trackeval",)
    threshold: float | None = None
    if trackers:  # our family parameters: reported, and the peers' pre-filter threshold
        try:
            cfg = ours_config(spec.family)
            threshold = ours_score_threshold(cfg)
            result.ours_config = _config_json(cfg)
        except Exception as exc:  # the tracker may not be importable yet: peers still run
            log.warning(
                "%s: our tracker's configuration is unavailable (%s); "
                "peers run without pre-filter",
                spec.name,
                exc,
            )
    # every pass on one sequence before the next sequence, so that a slow spell of a shared
    # machine falls on all trackers alike (the time ratios are measured in one run)
    passes = [
        (name, pass_name, min_score)
        for name in trackers
        for pass_name, min_score in _passes(name, threshold)
    ]
    runs: dict[tuple[str, str], dict[str, TrackerRun]] = {(n, p): {} for n, p, _ in passes}
    times: dict[tuple[str, str], list[np.ndarray]] = {(n, p): [] for n, p, _ in passes}
    failed: dict[tuple[str, str], TrackerRun] = {}
    explained = (
        BenchmarkExplanations(
            log_dir=output_dir / spec.name, warnings=monitors_warnings(spec, all_warnings)
        )
        if explanations
        else None
    )
    for i, seq in enumerate(bench.sequences, 1):
        say(
            f"[{spec.name}] sequence {seq.name} ({i}/{len(bench.sequences)}): "
            f"{len(passes)} tracking passes"
        )
        for name, pass_name, min_score in passes:
            key = (name, pass_name)
            if key in failed:
                continue
            try:
                tracks, seconds = None, None
                # the first run's results, the fastest run's times; boxmot peers run once (seven
                # more trackers at ~1 ms per frame would triple the run)
                for _ in range(1 if name in BOXMOT_PEERS else repeat):
                    tracker = _make_tracker(name, pass_name, spec, seq, min_score)
                    capture = None
                    first_of_ours = name == "ours" and tracks is None
                    if (
                        explained is not None
                        and first_of_ours
                        and isinstance(tracker, OursAdapter)
                    ):
                        events_log, warnings_log = log_paths(output_dir / spec.name, seq.name)
                        capture = SequenceCapture(
                            spec, seq, events_log, warnings_log if explained.warnings else None
                        )
                        tracker.observer = capture
                    try:
                        got, took = run_sequence(tracker, seq, frames_per_seq[seq.name])
                    except BaseException:
                        if capture is not None:
                            capture.abort()
                        raise
                    if capture is not None and explained is not None:
                        capture.finish()
                        explained.monitor_seconds += capture.seconds
                    tracks = got if tracks is None else tracks
                    if seconds is None or took.sum() < seconds.sum():
                        seconds = took
                assert tracks is not None and seconds is not None  # at least one run
                times[key].append(seconds)
                log.info(
                    "%s: %s (%s) %s: %d frames, %.2f ms/frame, slowest %.0f ms",
                    spec.name,
                    name,
                    pass_name,
                    seq.name,
                    seconds.size,
                    1000 * seconds.mean() if seconds.size else 0.0,
                    1000 * seconds.max() if seconds.size else 0.0,
                )
                for variant, out in _outputs(name, pass_name, tracks).items():
                    run_ = runs[key].get(variant)
                    if run_ is None:
                        run_ = runs[key][variant] = TrackerRun(
                            tracker=name,
                            variant=variant,
                            min_score=min_score,
                            result_dir=output_dir / spec.name / _label(name, variant),
                        )
                    assert run_.result_dir is not None  # set when the run was made
                    write_results(spec, run_.result_dir / f"{seq.name}.txt", out)
            except MissingExtraError:
                raise
            except Exception as exc:
                failed[key] = _failed_run(spec.name, name, pass_name, min_score, exc, "tracking")
    for name, pass_name, min_score in passes:
        key = (name, pass_name)
        if key not in failed:
            try:
                per_frame = np.concatenate(times[key]) if times[key] else np.zeros(0)
                for run_ in runs[key].values():
                    run_.set_times(per_frame)
                    assert run_.result_dir is not None  # set when the run was made
                    scores = _evaluate(bench, run_.result_dir, gt, modes)
                    run_.metrics, run_.per_sequence = scores["trackeval"]
                    if "kitti_legacy" in scores:
                        run_.legacy = scores["kitti_legacy"][0]
            except MissingExtraError:
                raise
            except Exception as exc:
                failed[key] = _failed_run(spec.name, name, pass_name, min_score, exc, "evaluating")
        if key in failed:
            result.runs.setdefault(name, []).append(failed[key])
            say(f"[{spec.name}] {_label(name, pass_name)}: FAILED {failed[key].error}")
            continue
        for variant, run_ in runs[key].items():
            result.runs.setdefault(name, []).append(run_)
            m = run_.metrics
            say(
                f"[{spec.name}] {_label(name, variant):<20} {run_.frames:>6} frames "
                f"{run_.ms_per_frame:8.2f} ms/frame  HOTA {100 * m.get('HOTA', np.nan):5.1f}  "
                f"MOTA {100 * m.get('MOTA', np.nan):5.1f}  "
                f"IDF1 {100 * m.get('IDF1', np.nan):5.1f}  "
                f"IDSW {m.get('IDSW', np.nan):.0f}"
            )
    ours_run = runs.get(("ours", "config"), {}).get("visible")
    if explained is not None and ours_run is not None and ("ours", "config") not in failed:
        result.explanations = _judge_explanations(bench, ours_run, explained, say)
    return result


def _judge_explanations(
    bench: Benchmark, ours: TrackerRun, explained: BenchmarkExplanations, say: Progress
) -> BenchmarkExplanations:
    """Judge our logs of every sequence against the ground truth (a failure is reported, the
    tracking results stand)."""
    start = time.perf_counter()
    assert ours.result_dir is not None and explained.log_dir is not None  # set above
    try:
        explained.results = judge_all(
            bench.spec, bench.sequences, ours.result_dir, explained.log_dir, explained.warnings
        )
    except MissingExtraError:
        raise
    except Exception as exc:
        log.exception("%s: judging the explanations failed", bench.spec.name)
        explained.error = f"{type(exc).__name__}: {exc}"
    explained.judge_seconds = time.perf_counter() - start
    if explained.error is not None:
        say(f"[{bench.spec.name}] explanations: FAILED {explained.error}")
        return explained
    s = explained.summary()
    hides = s["events"]["hides_behind"]
    precision = hides["precision"]
    n_events = sum(len(r.events) for r in explained.results)
    n_warnings = sum(len(r.warnings) for r in explained.results)
    judged = (
        f"{n_events} events, {n_warnings} warnings judged"
        if explained.warnings
        else f"{n_events} events judged (no situation monitor here)"
    )
    say(
        f"[{bench.spec.name}] explanations: {judged}; hides_behind {hides['total']}, precision "
        f"{'-' if precision is None else f'{100 * precision:.1f} %'} "
        f"({'monitor and ' if explained.warnings else ''}logs "
        f"{explained.monitor_seconds:.1f} s, judging {explained.judge_seconds:.1f} s)"
    )
    return explained


def _failed_run(
    bench: str, name: str, pass_name: str, min_score: float | None, exc: Exception, step: str
) -> TrackerRun:
    """A run that failed at ``step`` (logged with its traceback), for the report."""
    log.exception("%s: %s %s (%s) failed", bench, step, name, pass_name)
    return TrackerRun(
        tracker=name, variant=pass_name, min_score=min_score, error=f"{type(exc).__name__}: {exc}"
    )


def _config_json(cfg: Any) -> dict[str, Any]:
    try:
        d = cfg.to_dict()
    except AttributeError:
        from dataclasses import asdict

        d = asdict(cfg)
    return _jsonable(d)


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if x is None or isinstance(x, (int, float, str, bool)):
        return x
    return repr(x)


def _run_one(
    spec: BenchmarkSpec,
    sources: list[Any],
    skipped: list[str] | None,
    trackers: list[str],
    out_dir: Path,
    repeat: int = 1,
    explanations: bool = True,
    all_warnings: bool = False,
) -> tuple[BenchmarkRun, list[str]]:
    """One benchmark in a worker process: its result and its progress lines."""
    lines: list[str] = []
    bench = load_benchmark(spec, sources, skipped)
    lines.append(f"[{spec.name}] {len(bench.sequences)} sequences, {bench.n_frames} frames")
    result = run_benchmark(
        bench, trackers, out_dir, lines.append, repeat, explanations, all_warnings
    )
    return result, lines


def _cross_validate(found: Any, out_dir: Path, say: Progress) -> list[Any]:
    """Cross-validation of every family found (benchmarks loaded again: workers do not return
    them)."""
    families: dict[str, list[Benchmark]] = {}
    for spec, sources in found.found:
        families.setdefault(family_of(spec), []).append(
            load_benchmark(spec, sources, found.skipped.get(spec.name))
        )
    out = []
    for family, benches in families.items():
        folds = {fold_key(b.spec, s.name) for b in benches for s in b.sequences}
        if len(folds) < 2:
            say(f"[crossval {family}] skipped: one video only, nothing to hold out")
            continue
        say(f"[crossval {family}] {len(benches)} benchmarks: leave one video out over a grid")
        out.append(cross_validate(benches, out_dir, progress=say))
    return out


def run(
    data: str | Path | None = None,
    output: str | Path = "out/benchmark",
    only: Iterable[str] | None = None,
    trackers: Iterable[str] | str | None = None,
    progress: Progress | None = None,
    command: str = "",
    jobs: int = 1,
    repeat: int = 1,
    crossval: bool = True,
    explanations: bool = True,
    all_warnings: bool = False,
) -> RunSummary:
    """Discover, track, write, evaluate: the whole benchmark in one call.

    Args:
        data: the data folder (default ``../shared/data``).
        output: folder for result files (created).
        only: benchmark names or patterns (default: every benchmark found).
        trackers: tracker keys (default: all of :data:`TRACKER_NAMES`).
        progress: called with one line per finished step (the CLI prints them).
        command: the command line that reproduces this run (for the report).
        jobs: benchmarks run at once in worker processes (1: all in this process). Every tracker
            of a benchmark runs in the same process, one after the other, so the time ratios to
            ours compare like with like; with more jobs than idle cores the absolute times grow.
        repeat: runs of every tracker on every sequence; the fastest one's times count (the
            results are the same in every run). Trackers alternate sequence by sequence.
        crossval: also cross-validate our parameters (leave one video out within each family,
            :mod:`~sensemaking.benchmark.crossval`) when ``ours`` is among the trackers.
        explanations: also judge the events and warnings of ours with abduction against the
            ground truth (:mod:`~sensemaking.benchmark.explanations`).
        all_warnings: run the situation monitor (and judge its warnings) on every benchmark,
            not only on the KITTI car benchmarks.
    """
    start = time.perf_counter()
    say = progress or (lambda msg: None)
    chosen = parse_trackers(trackers)
    from sensemaking.errors import require

    if any(t in TRACKERS_PEERS for t in chosen):
        require("trackers", "benchmark")
    if any(t in BOXMOT_PEERS for t in chosen):
        require("boxmot", "boxmot")
    if jobs < 1:
        raise InputError(f"jobs must be at least 1, got {jobs}")
    if repeat < 1:
        raise InputError(f"repeat must be at least 1, got {repeat}")
    found = discover(data, only)
    if not found.found:  # before any output is written (the report would be empty)
        skipped = "; ".join(found.all_skipped())
        raise InputError(
            "no benchmark found"
            + (f" ({skipped})" if skipped else ": give the data folder with --data"),
            data,
        )
    out_dir = Path(output)
    out_dir.mkdir(parents=True, exist_ok=True)
    summary = RunSummary(
        benchmarks=[],
        skipped=found.all_skipped(),
        trackers=chosen,
        data_root=str(data if data is not None else found.root),
        output_dir=str(out_dir),
        command=command,
        started=datetime.now(UTC).isoformat(timespec="seconds"),
        machine=machine_info(),
    )
    summary.machine["jobs"] = jobs
    summary.machine["repeat"] = repeat
    summary.machine["explanations"] = explanations
    summary.machine["all_warnings"] = all_warnings
    summary.peer_defaults = {name: peer_defaults(name) for name in chosen if name in PEERS}
    for msg in summary.skipped:
        say(f"skipped: {msg}")
    if not found.found:
        say("no benchmark found")
    if jobs == 1 or len(found.found) <= 1:
        for spec, sources in found.found:
            bench = load_benchmark(spec, sources, found.skipped.get(spec.name))
            say(f"[{spec.name}] {len(bench.sequences)} sequences, {bench.n_frames} frames")
            summary.benchmarks.append(
                run_benchmark(bench, chosen, out_dir, progress, repeat, explanations, all_warnings)
            )
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        results: dict[str, BenchmarkRun] = {}
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            # biggest detection files first: the longest benchmarks start at once (load balancing)
            order = sorted(
                found.found, key=lambda item: -sum(src.det_path.stat().st_size for src in item[1])
            )
            futures = {
                pool.submit(
                    _run_one,
                    spec,
                    sources,
                    found.skipped.get(spec.name),
                    chosen,
                    out_dir,
                    repeat,
                    explanations,
                    all_warnings,
                ): spec
                for spec, sources in order
            }
            say(f"running {len(futures)} benchmarks, {jobs} at a time")
            for fut in as_completed(futures):
                bench_run, lines = fut.result()
                for line in lines:
                    say(line)
                results[futures[fut].name] = bench_run
        summary.benchmarks = [results[spec.name] for spec, _ in found.found]
    if crossval and "ours" in chosen:
        summary.crossval = _cross_validate(found, out_dir, say)
    summary.total_seconds = time.perf_counter() - start
    summary.machine["load_average_end"] = _load_average()
    say(f"total {summary.total_seconds:.1f} s")
    return summary

"""Explanation quality in the benchmark run: are our tracker's events and warnings true?

The runner's tracking pass of ``ours`` (with abduction) hands every frame's full result to a
:class:`SequenceCapture` (outside the timed ``update`` call): the event log is written as
``track --events`` writes it, to ``<output>/<benchmark>/ours-explanations/<seq>.events.jsonl``.
Where warnings are judged (:func:`monitors_warnings`: KITTI cars, whose labels have the 3D
positions the warning targets need, or every benchmark on request) the situation monitor runs
on it as ``sensemaking track --warnings`` runs it, its warnings going to ``<seq>.warnings.jsonl``.
The monitor costs more than the tracker on a busy scene (clingo per frame over every near
pair), hence not everywhere by default. After the pass, :func:`judge_sequence` reads the visible
tracks file, the logs and the ground truth back from disk, as ``sensemaking evaluate
--explanations`` does, and judges every event and warning
(:mod:`sensemaking.evaluation.explanations`, method in docs/EXPLANATIONS.md).
``benchmarks/explanation_quality.py`` is this same path with ``ours`` alone.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sensemaking.evaluation.explanations import (
    EVENT_KINDS,
    WARNING_KINDS,
    ExplanationConfig,
    ExplanationResult,
    GroundTruth,
    evaluate_explanations,
    load_ground_truth,
)
from sensemaking.records import read_events, read_warnings

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.benchmark.datasets import BenchmarkSpec, Sequence
    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.results import FrameResult

__all__ = [
    "EXPLANATIONS_DIR",
    "BenchmarkExplanations",
    "SequenceCapture",
    "log_paths",
    "monitors_warnings",
    "situation_monitor",
    "judge_all",
    "ground_truth",
    "judge_sequence",
]

log = logging.getLogger(__name__)

#: folder (under ``<output>/<benchmark>/``) of our event and warning logs
EXPLANATIONS_DIR = "ours-explanations"


def log_paths(bench_dir: Path, sequence: str) -> tuple[Path, Path]:
    """``(events, warnings)`` JSON-lines files of one sequence under ``bench_dir``."""
    folder = Path(bench_dir) / EXPLANATIONS_DIR
    return folder / f"{sequence}.events.jsonl", folder / f"{sequence}.warnings.jsonl"


def monitors_warnings(spec: BenchmarkSpec, everywhere: bool = False) -> bool:
    """Whether the benchmark run judges warnings on ``spec``: on KITTI cars (3D labels, so
    SUDDEN_STOP and OVERTAKING are decidable; issue 15's warning targets are stated on these
    runs), or on every benchmark when ``everywhere``."""
    return everywhere or (spec.family == "kitti" and (spec.class_name or "").lower() == "car")


def situation_monitor(spec: BenchmarkSpec, seq: Sequence) -> SituationMonitor:
    """The situation monitor ``sensemaking track --warnings`` runs on this sequence: every
    situation, the sequence's frame rate and image size, the family's scene profile and, on
    KITTI, KITTI's camera model (as ``track --format kitti``)."""
    from sensemaking.reasoning.egomotion import CameraModel
    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.settings import preset_profile

    return SituationMonitor(
        fps=float(seq.info.fps),
        image_size=(int(seq.info.width), int(seq.info.height)),
        profile=preset_profile(spec.family),
        camera=CameraModel.kitti() if spec.family == "kitti" else None,
    )


class SequenceCapture:
    """Called with each frame's :class:`~sensemaking.results.FrameResult` of one sequence, in
    order: writes the event log and, with a ``warnings_path``, runs the situation monitor and
    writes its warnings (the sinks of ``sensemaking track``). ``finish()`` commits the files,
    ``abort()`` removes them; ``seconds`` is the wall time spent here (monitor and writing)."""

    def __init__(
        self,
        spec: BenchmarkSpec,
        seq: Sequence,
        events_path: Path,
        warnings_path: Path | None = None,
    ):
        from sensemaking.sinks import EventsSink, Sink, WarningsSink

        events_path.parent.mkdir(parents=True, exist_ok=True)
        self.monitor = None if warnings_path is None else situation_monitor(spec, seq)
        self.sinks: list[Sink] = [EventsSink(events_path)]
        if warnings_path is not None:
            self.sinks.append(WarningsSink(warnings_path))
        self.seconds = 0.0

    def __call__(self, result: FrameResult) -> None:
        start = time.perf_counter()
        warnings = [] if self.monitor is None else self.monitor.update(result)
        for sink in self.sinks:
            sink.frame(result, warnings)
        self.seconds += time.perf_counter() - start

    def finish(self) -> None:
        for sink in self.sinks:
            sink.finish()

    def abort(self) -> None:
        for sink in self.sinks:
            sink.abort()


def ground_truth(spec: BenchmarkSpec, seq: Sequence) -> GroundTruth:
    """The sequence's ground truth for the judge: KITTI labels of the benchmark's class (and its
    distractor class), or the MOTChallenge ``gt.txt``."""
    return load_ground_truth(
        seq.gt_path,
        "kitti" if spec.output_format == "kitti" else "mot",
        image_size=(int(seq.info.width), int(seq.info.height)),
        fps=float(seq.info.fps),
        classes=(spec.class_name or "pedestrian",),
        n_frames=int(seq.info.length),
    )


def judge_sequence(
    spec: BenchmarkSpec,
    seq: Sequence,
    tracks_path: Path,
    events_path: Path,
    warnings_path: Path | None,
    config: ExplanationConfig | None = None,
) -> ExplanationResult:
    """Judge one sequence from its files: the visible tracks (the benchmark's result format),
    the event log and the warnings (None: no warnings judged)."""
    if spec.output_format == "kitti":
        from sensemaking.io.kitti import read_kitti_labels

        tracks = read_kitti_labels(tracks_path)
    else:
        from sensemaking.io.mot import read_mot

        tracks = read_mot(tracks_path, kind="results")
    events = read_events(events_path)
    warnings = read_warnings(warnings_path) if warnings_path is not None else []
    return evaluate_explanations(
        ground_truth(spec, seq), tracks, events, warnings, name=seq.name, config=config
    )


@dataclass
class BenchmarkExplanations:
    """Explanation quality of ours (with abduction) on one benchmark.

    Attributes:
        results: one :class:`ExplanationResult` per sequence (every verdict), in run order.
        log_dir: the folder of the event and warning logs.
        warnings: the situation monitor ran and its warnings were judged
            (:func:`monitors_warnings`).
        monitor_seconds: wall time of the situation monitor and the log writing during the
            tracking pass (all sequences).
        judge_seconds: wall time of reading the files back and judging them.
        error: why the judgement failed, or None.
    """

    results: list[ExplanationResult] = field(default_factory=list)
    log_dir: Path | None = None
    warnings: bool = True
    monitor_seconds: float = 0.0
    judge_seconds: float = 0.0
    error: str | None = None

    @property
    def seconds(self) -> float:
        """What the explanation part added to the run (monitor, logs, judging)."""
        return self.monitor_seconds + self.judge_seconds

    def summary(self) -> dict[str, Any]:
        """:meth:`ExplanationResult.summary` of all sequences together."""
        return ExplanationResult.combine(self.results).summary()

    def to_json(self) -> dict[str, Any]:
        """The combined summary, compact counts per sequence and the timing (every verdict is
        one ``sensemaking evaluate --explanations --json`` away, from the logs)."""
        return {
            "log_dir": None if self.log_dir is None else str(self.log_dir),
            "warnings_judged": self.warnings,
            "monitor_seconds": self.monitor_seconds,
            "judge_seconds": self.judge_seconds,
            "error": self.error,
            "summary": self.summary(),
            "per_sequence": {r.name: _counts(r.summary()) for r in self.results},
        }


def _counts(summary: Mapping[str, Any]) -> dict[str, Any]:
    """``kind -> [plausible, implausible, undecidable]`` of the kinds that occur."""
    out: dict[str, Any] = {}
    for group, kinds in (("events", EVENT_KINDS), ("warnings", WARNING_KINDS)):
        for kind in kinds:
            row = summary[group][kind]
            if row["total"]:
                out[kind] = [row["plausible"], row["implausible"], row["undecidable"]]
    return out


def judge_all(
    spec: BenchmarkSpec,
    sequences: Iterable[Sequence],
    tracks_dir: Path,
    bench_dir: Path,
    warnings: bool = True,
) -> list[ExplanationResult]:
    """:func:`judge_sequence` for every sequence: tracks ``<tracks_dir>/<seq>.txt``, logs by
    :func:`log_paths` under ``bench_dir`` (the warnings only with ``warnings``)."""
    out = []
    for seq in sequences:
        events, warned = log_paths(bench_dir, seq.name)
        tracks = tracks_dir / f"{seq.name}.txt"
        out.append(judge_sequence(spec, seq, tracks, events, warned if warnings else None))
    return out

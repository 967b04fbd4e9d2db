"""One sequence, start to end: detections in; tracks (visible and hidden), events, warnings and,
with ground truth, metrics out. Pure core (numpy, clingo): no Ray, no Parquet here.

:func:`run_sequence` is the whole per-sequence loop, kept in one function so that it can be
replaced by ``sensemaking.pipeline`` when that exists.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from sensemaking.errors import InputError
from sensemaking.fleet.specs import SequenceSpec

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.reasoning.situations import SituationWarning
    from sensemaking.results import Event
    from sensemaking.scene import Scene
    from sensemaking.tracker import TrackerConfig

__all__ = ["RunParams", "SequenceResult", "run_sequence", "tracker_config"]


@dataclass(frozen=True)
class RunParams:
    """The parameters a batch applies to every sequence, on top of the dataset family's set.

    Attributes:
        abduction: False runs plain Hungarian IoU matching (the ablation).
        overrides: ``(name, value)`` pairs of :class:`~sensemaking.tracker.TrackerConfig`
            fields (JSON values), sorted by name.
        max_solve_ms: per-frame solver budget in ms (None: none; results then do not depend on
            the machine's speed).
    """

    abduction: bool = True
    overrides: tuple[tuple[str, Any], ...] = ()
    max_solve_ms: float | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "abduction": self.abduction,
            "overrides": dict(self.overrides),
            "max_solve_ms": self.max_solve_ms,
        }

    @classmethod
    def from_strings(
        cls, items: list[str], abduction: bool = True, max_solve_ms: float | None = None
    ) -> RunParams:
        """From ``KEY=VALUE`` strings (``--set``: typed, dotted keys reach nested settings).

        Raises:
            InputError: a malformed item, an unknown parameter or a bad value.
        """
        from sensemaking import settings

        out = settings.parse_overrides(items)
        params = cls(abduction, tuple(sorted(out.items())), max_solve_ms)
        tracker_config(
            SequenceSpec("check", "check", "-", "mot"), params
        )  # fail early on values that do not go together
        return params


def tracker_config(spec: SequenceSpec, params: RunParams) -> TrackerConfig:
    """The tracker's parameters for ``spec``: family set, the sequence's fps and image size, then
    the batch's overrides.

    Raises:
        InputError: an override has a bad value.
    """
    from sensemaking import settings

    facts: dict[str, Any] = {"abduction": params.abduction, "max_solve_ms": params.max_solve_ms}
    if spec.fps:
        facts["fps"] = float(spec.fps)
    if spec.image_size:
        facts["image_size"] = (int(spec.image_size[0]), int(spec.image_size[1]))
    config = settings.apply_settings(settings.preset_config(spec.family), facts)
    return settings.apply_settings(config, dict(params.overrides), "--set")


@dataclass(eq=False)
class SequenceResult:
    """What :func:`run_sequence` found for one sequence.

    Attributes:
        spec: the sequence. config: the tracker parameters used (JSON-able).
        scene: every track's boxes and states per frame, and the event log.
        warnings: the safety-critical warnings, in order (notes of skipped situations are in
            ``skipped_situations``, not here).
        metrics: field -> value (CLEAR MOT, IDF1, HOTA, counts) when ground truth was given.
        stats: ``frames``, ``detections``, ``seconds`` (wall time of the loop), ``solve_ms``
            (tracker's solver), ``monitor_ms`` (situation monitor), ``timed_out`` frames.
    """

    spec: SequenceSpec
    config: dict[str, Any]
    scene: Scene
    warnings: list[SituationWarning]
    metrics: dict[str, float] | None
    stats: dict[str, float] = field(default_factory=dict)
    skipped_situations: dict[str, str] = field(default_factory=dict)

    @property
    def events(self) -> list[Event]:
        return self.scene.events


def _detections(spec: SequenceSpec):
    from sensemaking.classes import class_id
    from sensemaking.io.formats import read_detections

    fmt: Any = spec.fmt
    dets = read_detections(spec.det_path, fmt, class_name=spec.class_name)
    if spec.class_name and len(dets):
        dets = dets.with_(class_id=np.full(len(dets), class_id(spec.class_name), dtype=np.int64))
    if spec.logit_scores and len(dets):
        assert dets.confidence is not None  # set by __post_init__
        dets = dets.with_(confidence=1.0 / (1.0 + np.exp(-dets.confidence)))
    return dets


def _ground_truth(spec: SequenceSpec) -> Any:
    if spec.fmt == "kitti":
        from sensemaking.io.kitti import read_kitti_labels

        return read_kitti_labels(str(spec.gt_path))
    from sensemaking.io.mot import read_mot

    return read_mot(str(spec.gt_path), kind="gt")


def _score(spec: SequenceSpec, gt: Any, scene: Scene, n_frames: int) -> dict[str, float]:
    from sensemaking.detections import Detections
    from sensemaking.evaluation import PER_SEQUENCE_FIELDS, evaluate_sequence
    from sensemaking.results import TrackState

    parts = []
    for t in scene.tracks.values():
        seen = t.state == int(TrackState.VISIBLE)
        if seen.any():
            k = int(seen.sum())
            parts.append(
                Detections(
                    xyxy=t.xyxy[seen],
                    confidence=t.confidence[seen],
                    class_id=np.full(k, t.class_id),
                    tracker_id=np.full(k, t.id),
                    frame=t.frames[seen],
                )
            )
    tracks = Detections.concatenate(parts) if parts else Detections.empty()
    if len(tracks):
        assert tracks.frame is not None  # set by __post_init__
        tracks = tracks[np.argsort(tracks.frame, kind="stable")]
        if str(spec.rules).startswith("mot"):
            # MOT rules score one class (their "pedestrian"): the sequence's one class here
            tracks = tracks.with_(class_id=np.ones(len(tracks), dtype=np.int64))
    m = evaluate_sequence(
        gt, tracks, str(spec.rules), n_frames=n_frames, name=spec.sequence, gt_path=spec.gt_path
    )
    out: dict[str, float] = {}
    for key in PER_SEQUENCE_FIELDS:
        if key in m:
            out[key] = float(m[key])
    return out


class _Warnings:
    """A pipeline sink that keeps the warnings (notes that a situation was not checked aside)."""

    def __init__(self) -> None:
        self.warnings: list[SituationWarning] = []

    def frame(self, result: Any, warnings: list[SituationWarning]) -> None:
        self.warnings.extend(w for w in warnings if w.objects)

    def skip(self, first: int, last: int) -> None:
        pass

    def finish(self) -> None:
        pass

    def abort(self, interrupted: bool = False) -> None:
        pass


def run_sequence(spec: SequenceSpec, params: RunParams | None = None) -> SequenceResult:
    """Track one sequence with events, scene and warnings; score it when it has ground truth.

    Raises:
        InputError (or another SensemakingError): the sequence's input is bad.
    """
    from sensemaking import settings
    from sensemaking.lookahead import make_tracker
    from sensemaking.pipeline import Pipeline
    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.scene import SceneRecorder
    from sensemaking.tracker import Tracker

    params = params or RunParams()
    t0 = time.perf_counter()
    dets = _detections(spec)
    config = tracker_config(spec, params)
    gt = _ground_truth(spec) if spec.gt_path else None
    first = spec.first_frame
    last = int(dets.frame.max()) if len(dets) else first - 1
    if spec.n_frames is not None:
        # the stated length, but no further than the content and the longest a track can live
        # on without detections: work is bounded by the files, not by a number in them
        content = max(last, int(gt.frame.max()) if gt is not None and len(gt) else last)
        horizon = content + config.max_hidden_frames + config.max_missing_frames + 1
        last = max(last, min(first + int(spec.n_frames) - 1, horizon))
    if last < first:
        raise InputError("no detections and no sequence length: nothing to track", spec.det_path)
    tracker = make_tracker(Tracker(config))  # lookahead_s > 0: frames final k frames later
    recorder = SceneRecorder(
        fps=config.fps,
        image_size=config.image_size,
        metadata={"dataset": spec.dataset, "sequence": spec.sequence, "source": spec.det_path},
        problems=False,  # the archive keeps tables, not the abduction problems behind events
    )
    monitor = SituationMonitor(
        fps=config.fps,
        image_size=config.image_size,
        profile=settings.preset_profile(spec.family),  # the family's camera: ego vehicle or not
    )
    collected = _Warnings()
    frames = ((f, d) for f, d in dets.frames() if first <= f <= last)
    with Pipeline(tracker, recorder, monitor, [collected], validate=False) as pipe:
        pipe.run(frames, first_frame=first, last_frame=last)
    warnings = collected.warnings
    scene = recorder.scene()
    n_frames = last - first + 1
    metrics = _score(spec, gt, scene, n_frames) if gt is not None else None
    stats = {
        "frames": float(n_frames),
        "detections": float(len(dets)),
        "seconds": time.perf_counter() - t0,
        "solve_ms": float(tracker.stats["solve_ms"]),
        "monitor_ms": float(monitor.stats["ms"]),
        "timed_out": float(tracker.stats["timed_out"]),
    }
    return SequenceResult(
        spec, _jsonable(config.to_dict()), scene, warnings, metrics, stats, dict(monitor.skipped)
    )


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.integer, np.floating)):
        return x.item()
    return x

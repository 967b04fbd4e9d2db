"""One benchmark sequence, one tracker: our parameters for a dataset family, a tracking pass
over every frame, and the result and ground-truth files in the benchmark's format. Shared by
the runner and the cross-validation (neither imports the other's internals)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sensemaking.benchmark.datasets import BenchmarkSpec, Sequence
from sensemaking.benchmark.peers import FrameTracker
from sensemaking.detections import Detections

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.tracker import TrackerConfig

__all__ = [
    "ours_config",
    "ours_score_threshold",
    "frames_of",
    "run_sequence",
    "write_results",
    "read_gt",
    "read_results",
    "rules_name",
]


def ours_config(
    family: str,
    *,
    abduction: bool = True,
    fps: float | None = None,
    image_size: tuple[int, int] | None = None,
) -> TrackerConfig:
    """Our tracker's one named parameter set for a dataset family (``kitti`` / ``motchallenge``).

    The sequence's frame rate and image size are facts of the input, not tuned parameters: they
    are set per sequence (the peers get the frame rate too).
    """
    from sensemaking.tracker import TrackerConfig

    changes: dict[str, Any] = {"abduction": abduction}
    if fps is not None:
        changes["fps"] = float(fps)
    if image_size is not None:
        changes["image_size"] = (int(image_size[0]), int(image_size[1]))
    return TrackerConfig.for_dataset(family, **changes)


def ours_score_threshold(config: TrackerConfig) -> float:
    """The detection score our tracker needs to start a track: the peers' pre-filter threshold."""
    return float(config.start_confidence)


def frames_of(seq: Sequence) -> dict[int, Detections]:
    return dict(seq.detections.frames())


def run_sequence(
    tracker: FrameTracker, seq: Sequence, frames: dict[int, Detections] | None = None
) -> tuple[Detections, np.ndarray]:
    """Track one sequence from its first to its last frame (empty frames included).

    Returns:
        (every reported track of every frame, seconds inside the update call of each frame)
    """
    frames = frames_of(seq) if frames is None else frames
    tracker.reset()
    out: list[Detections] = []
    numbers = seq.frame_numbers
    seconds = np.zeros(len(numbers))
    for i, f in enumerate(numbers):
        dets = frames.get(f)
        if dets is None:
            dets = _empty_frame(seq.detections, f)
        tracks, seconds[i] = tracker.update(dets, f)
        if len(tracks):
            out.append(tracks)
    return (Detections.concatenate(out) if out else Detections.empty()), seconds


def _empty_frame(like: Detections, frame: int) -> Detections:
    """No detections, but with the data columns of ``like`` (so outputs concatenate)."""
    data = {k: v[:0] for k, v in like.data.items()}
    return Detections(xyxy=np.zeros((0, 4)), frame=np.zeros(0, dtype=np.int64), data=data)


def write_results(spec: BenchmarkSpec, path: Path, tracks: Detections) -> None:
    if spec.output_format == "kitti":
        from sensemaking.io.kitti import write_kitti

        write_kitti(path, tracks)
    else:
        from sensemaking.io.mot import write_mot

        write_mot(path, tracks)


def rules_name(spec: BenchmarkSpec) -> str:
    return f"kitti-{spec.class_name}" if spec.rules == "kitti" else spec.rules


def read_gt(spec: BenchmarkSpec, path: Path) -> Detections:
    if spec.output_format == "kitti":
        from sensemaking.io.kitti import read_kitti_labels

        return read_kitti_labels(path)
    from sensemaking.io.mot import read_mot

    return read_mot(path, kind="gt")


def read_results(spec: BenchmarkSpec, path: Path) -> Detections:
    if spec.output_format == "kitti":
        from sensemaking.io.kitti import read_kitti_labels

        return read_kitti_labels(path)
    from sensemaking.io.mot import read_mot

    return read_mot(path, kind="results")

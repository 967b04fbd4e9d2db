"""Entry points: :func:`evaluate_sequence` (one sequence) and :func:`evaluate` (a benchmark)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from sensemaking.detections import Detections
from sensemaking.evaluation._prepare import PathLike, prepare
from sensemaking.evaluation.metrics import (
    IDSW_MODES,
    clear_metrics,
    count_metrics,
    hota_metrics,
    identity_metrics,
)
from sensemaking.evaluation.report import COMBINED, Report, SequenceMetrics
from sensemaking.evaluation.rules import DatasetRules, get_rules, rules_for_benchmark

__all__ = ["SequenceInput", "evaluate_sequence", "evaluate"]


@dataclass(frozen=True, eq=False)
class SequenceInput:
    """One sequence to score: ground truth, tracker output, length in frames (None: inferred from
    the boxes) and the files they came from (for error messages only)."""

    gt: Detections
    tracks: Detections
    n_frames: int | None = None
    gt_path: PathLike = None
    tracks_path: PathLike = None


SequenceArg = SequenceInput | tuple[Detections, Detections] | tuple[Detections, Detections, int]
RulesArg = DatasetRules | str | Sequence[DatasetRules | str]


def _check_mode(idsw_mode: str) -> None:
    if idsw_mode not in IDSW_MODES:
        raise ValueError(f"idsw_mode must be one of {', '.join(IDSW_MODES)}, got {idsw_mode!r}")


def evaluate_sequence(
    gt: Detections,
    tracks: Detections,
    rules: DatasetRules | str,
    *,
    n_frames: int | None = None,
    idsw_mode: str = "trackeval",
    name: str = "",
    gt_path: PathLike = None,
    tracks_path: PathLike = None,
) -> SequenceMetrics:
    """Score one sequence: CLEAR, Identity, HOTA and Count fields (TrackEval semantics).

    Args:
        gt: ground truth; ``tracker_id`` is the object id, ``class_id`` and ``data`` columns
            ``consider`` (MOT), ``occluded`` / ``truncated`` (KITTI) as the rules need them
            (missing columns count as 1 / 0 / 0).
        tracks: tracker output; ``tracker_id`` is the track id.
        rules: :class:`DatasetRules` or a name: ``mot17``, ``mot16``, ``mot20``, ``mot15``,
            ``kitti-car``, ``kitti-pedestrian``.
        n_frames: sequence length; frames outside ``first .. first + n_frames - 1`` raise
            :class:`~sensemaking.errors.InputError` (None: inferred from the boxes).
        idsw_mode: ``"trackeval"`` or ``"kitti_legacy"``
            (see :mod:`~sensemaking.evaluation.metrics`).
        name: sequence name for the result.
        gt_path, tracks_path: source files, only to name them in errors.

    Boxes are scored as given: boxes partly or wholly outside the image are not clipped.
    """
    _check_mode(idsw_mode)
    r = get_rules(rules)
    data = prepare(gt, tracks, r, n_frames, gt_path=gt_path, tracks_path=tracks_path)
    parts = {
        "clear": clear_metrics(data, r.threshold, idsw_mode),
        "identity": identity_metrics(data, r.threshold),
        "hota": hota_metrics(data),
        "count": count_metrics(data),
    }
    return SequenceMetrics(name=name, class_name=r.class_name, idsw_mode=idsw_mode, parts=parts)


def _as_input(value: SequenceArg, n_frames: int | None) -> SequenceInput:
    if isinstance(value, SequenceInput):
        return value
    if isinstance(value, tuple) and len(value) in (2, 3):
        gt, tracks = value[0], value[1]
        n = value[2] if len(value) == 3 else n_frames
        return SequenceInput(gt=gt, tracks=tracks, n_frames=n)
    raise TypeError("each sequence must be a SequenceInput or a tuple (gt, tracks[, n_frames])")


def _rules_list(rules: RulesArg) -> list[DatasetRules]:
    if isinstance(rules, DatasetRules):
        return [rules]
    if isinstance(rules, str):
        return rules_for_benchmark(rules)
    out = [get_rules(r) for r in rules]
    if not out:
        raise ValueError("no rules given")
    return out


def evaluate(
    sequences: Mapping[str, SequenceArg],
    rules: RulesArg,
    *,
    idsw_mode: str = "trackeval",
    n_frames: Mapping[str, int] | None = None,
) -> Report:
    """Score several sequences and combine them (per class: each sequence plus ``"COMBINED"``).

    Args:
        sequences: name -> :class:`SequenceInput`, ``(gt, tracks)`` or ``(gt, tracks, n_frames)``.
        rules: rules, a rules name, a benchmark name (``"kitti"`` scores car and pedestrian) or a
            list of rules (one report block each).
        idsw_mode: ``"trackeval"`` or ``"kitti_legacy"``; the report records it.
        n_frames: sequence lengths by name, for inputs given as ``(gt, tracks)``.
    """
    _check_mode(idsw_mode)
    if not sequences:
        raise ValueError("no sequences to evaluate")
    rules_list = _rules_list(rules)
    inputs = {name: _as_input(v, (n_frames or {}).get(name)) for name, v in sequences.items()}
    if COMBINED in inputs:
        raise ValueError(f"{COMBINED!r} cannot be a sequence name")
    results: dict[str, dict[str, SequenceMetrics]] = {}
    for r in rules_list:
        per_seq = {
            name: evaluate_sequence(
                s.gt,
                s.tracks,
                r,
                n_frames=s.n_frames,
                idsw_mode=idsw_mode,
                name=name,
                gt_path=s.gt_path,
                tracks_path=s.tracks_path,
            )
            for name, s in inputs.items()
        }
        per_seq[COMBINED] = SequenceMetrics.combine(list(per_seq.values()))
        key = r.class_name if r.class_name not in results else r.label
        results[key] = per_seq
    benchmarks = {r.benchmark for r in rules_list}
    thresholds = {r.threshold for r in rules_list}
    return Report(
        benchmark="+".join(sorted(benchmarks)),
        idsw_mode=idsw_mode,
        results=results,
        threshold=thresholds.pop() if len(thresholds) == 1 else rules_list[0].threshold,
    )

"""Cross-validation of our tracker's parameters: leave one video out, within each family.

The family presets (``presets/kitti.json``, ``presets/mot.json``) were chosen on the same
sequences the benchmark reports, so the benchmark tables are in-sample. Here every sequence is
instead scored with parameters chosen *without* it:

1. Every point of a small grid (:data:`GRID`: the few parameters that matter most, each over two
   or three values around the preset) runs once on every sequence of every benchmark of the
   family; each (grid point, benchmark, sequence) is scored on its own (result files written and
   read back, as the runner does).
2. Folds are videos (:func:`fold_key`): a KITTI sequence number (held out from RRC and PointRCNN,
   car and pedestrian alike), a MOT17 sequence (YOLOX half and public FRCNN alike), a MOT15
   sequence. For each fold the grid point is chosen on the other folds by *least worst regret*
   (values flat across folds rather than the best mean): on each training video, a point's
   score is the mean over the family's benchmarks of its HOTA on that video, its regret the
   distance to the best point's score there; the point whose largest regret over the training
   videos is smallest is chosen (ties: the better training objective, then the earlier point).
   The training objective is the mean over the family's benchmarks of the HOTA of their
   remaining sequences, combined as TrackEval combines sequences; the choice by the best
   training objective alone (rule ``mean``) is kept beside it for comparison.
3. The held-out sequence is scored with its fold's choice; the cross-validated number of a
   benchmark combines its sequences so scored. Beside it: the *in-sample* number (the grid point
   chosen on every sequence, scored on the same sequences) and the preset's own.

The grid point chosen by most folds (ties: the better in-sample objective) is the *recommended*
set: values flat across folds rather than the best mean.

Rule ``calibrate`` (beside the grid): for each fold, :func:`sensemaking.calibrate.calibrate` runs
on every *other* video of the family, all its benchmarks *pooled* (every detector and class that
shares the preset: one list of annotated sequences, so a detection counts once wherever it comes
from and the family's thresholds are where the pooled P(true | score) crosses), and the held-out
video is tracked with the preset changed by the estimated values. Its in-sample twin calibrates
on every video. :func:`calibrate_verdict` says whether calibrate is as good as the grid. Beside
it, for diagnosis: calibrate *per detector* (each benchmark on its own other videos, as a user
calibrates their own detector) and each group of estimates alone (:data:`CALIBRATE_GROUPS`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import re
import time
from collections import Counter
from collections.abc import Callable, Mapping
from collections.abc import Sequence as SequenceABC
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.benchmark.datasets import Benchmark, BenchmarkSpec
from sensemaking.benchmark.peers import OursAdapter
from sensemaking.benchmark.sequences import (
    ours_config,
    read_gt,
    read_results,
    rules_name,
    run_sequence,
    write_results,
)

__all__ = [
    "GRID",
    "fold_key",
    "grid_points",
    "FamilyCV",
    "cross_validate",
    "family_of",
    "calibration_sequence",
    "calibrate_verdict",
]

log = logging.getLogger(__name__)

#: family -> parameter -> values tried (every combination is a grid point; the preset's own
#: values are among them). Kept small: the whole benchmark run must stay under 30 minutes.
#: ``costs.appears`` (250 / 400) was a fourth axis in a first run and moved the KITTI mean HOTA
#: by at most 0.05 at the best points (docs/DESIGN-NOTES.md), so it stays at the preset.
GRID: dict[str, dict[str, tuple[Any, ...]]] = {
    "kitti": {
        "start_confidence": (0.6, 0.7, 0.8),
        "min_confidence": (0.5, 0.65),
        "min_hits": (2, 3),
    },
    "mot": {
        "start_confidence": (0.6, 0.7, 0.8),
        "min_confidence": (0.5, 0.6),
        "min_hits": (1, 2),
    },
}
#: how a fold chooses its parameters: the headline rule first; ``calibrate`` estimates them
RULES = ("minimax", "mean", "calibrate")
_HAND = (
    "hand-chosen on the shared sequences, then checked leave one video out against other "
    "values: the folds keep it (docs/DESIGN-NOTES.md)"
)
_DEEPSORT = "DeepSORT's value (KalmanConfig), not tuned"
#: where the value of each parameter comes from, when it is neither on the grid nor estimated by
#: calibrate for the presets (one line each; read by docs/PARAMETERS.md)
ORIGINS: dict[str, str] = {
    "abduction": "the method: on; off is the benchmark's *ours, no abduction*.",
    "fps": "input: the sequence's frame rate (seqinfo, `--fps`); the preset's is the "
    "family's usual rate, used when nothing says it.",
    "image_size": "input: seqinfo's image size (`--image-size`).",
    "iou_assign": f"{_HAND} (KITTI 0.2; default 0.3).",
    "iou_resume": f"{_HAND} (0.2 in both presets).",
    "resume_growth": "default, a design choice (an unseen box widens 5 % per frame, at most "
    "2x), not tuned.",
    "new_track_growth": "default, a design choice (velocity unknown after one box), not tuned.",
    "min_confidence": "",
    "start_confidence": "",
    "class_confidence": "{} (one threshold for every class); lower pedestrian thresholds "
    "measured leave one video out, not kept (issue 27, docs/DESIGN-NOTES.md).",
    "max_hidden_s": "default 3 s: how long an occluded object is kept (the paper's horizon), "
    "not tuned.",
    "max_missing_s": "default 1 s; calibrate estimates it from the gaps of annotated objects.",
    "min_hits": "",
    "confirm_confidence": f"{_HAND} (KITTI 0.99); calibrate estimates it as P(true) >= 0.99.",
    "hide_cover": "default, the definition of being hidden (half the box covered), not tuned.",
    "emerge_margin": "default, a design choice, not tuned.",
    "keep_cover": "default, hysteresis of hide_cover, not tuned.",
    "hide_sure_cover": "explanations only (issue 22): chosen by leave-one-video-out on the "
    "shared sequences' checker precision (docs/DESIGN-NOTES.md).",
    "late_hides": "default: on (off moved mot15 HOTA by -0.3; docs/DESIGN-NOTES.md, issue 22).",
    "late_hide_cover": "explanations only (issue 22), with late_hides; see late_hides.",
    "late_maybe": "explanations only (issue 22): leave-one-video-out on the shared "
    "sequences' checker precision; the tracks do not change (docs/DESIGN-NOTES.md).",
    "late_confidence": "explanations only (issue 22): the weight of a late hiding's "
    "confidence, from its measured precision (docs/DESIGN-NOTES.md).",
    "depth_clear": "explanations only (issue 22): a hiding's confidence, in-sample on the "
    "shared sequences' checker precision (docs/DESIGN-NOTES.md); no event changes.",
    "depth_confidence": "explanations only (issue 22): see depth_clear.",
    "partial_cover": "default, the definition of partial occlusion, not tuned.",
    "border_margin": "default 10 px, the definition of *at the border* (calibrate uses the "
    "same), not tuned.",
    "class_aware": "switch: on (a track keeps its class).",
    "inherit_motion": "switch: on, a technique (docs/DESIGN-NOTES.md).",
    "resume_reupdate": "switch: off; a technique measured across folds, not kept "
    "(docs/DESIGN-NOTES.md).",
    "scene_shift": "switch: off; a technique measured across folds, not kept "
    "(docs/DESIGN-NOTES.md).",
    "unseen_damping": "1 (off); a technique of issue 27, measured across folds "
    "(docs/DESIGN-NOTES.md).",
    "revive_s": "0 (off); a technique of issue 27, measured across folds (docs/DESIGN-NOTES.md).",
    "revive_hold": "used only with revive_s; measured both ways (docs/DESIGN-NOTES.md).",
    "revive_height_ratio": "used only with revive_s; a design choice, not tuned.",
    "resume_last_seen": "switch: off; OC-SORT's observation-centric recovery, a technique of "
    "issue 27 measured across folds (docs/DESIGN-NOTES.md).",
    "lookahead_s": "0 (online); the fixed-lag look-ahead of issue 27, measured across "
    "folds (docs/DESIGN-NOTES.md).",
    "lookahead_margin": "used only with lookahead_s; a work bound, not tuned.",
    "lookahead_hypotheses": "used only with lookahead_s; N-best pruning, a work bound, not tuned.",
    "lookahead_continuity": "0 (off); used only with lookahead_s, measured across folds "
    "(docs/DESIGN-NOTES.md).",
    "lookahead_crowd_budget": "switch: off; used only with lookahead_s, a work bound measured "
    "with it (docs/DESIGN-NOTES.md).",
    "direction_weight": "0 (off); motion-direction consistency of issue 27, measured across "
    "folds (docs/DESIGN-NOTES.md).",
    "direction_min_speed": "used only with direction_weight; a design choice, not tuned.",
    "direction_span_s": "used only with direction_weight; longer than OC-SORT's 3 frames at "
    "30 fps (jitter), a design choice, not tuned.",
    "size_weight": "0 (off); size consistency of a resume, issue 27, measured across folds "
    "(docs/DESIGN-NOTES.md).",
    "swap_weight": "0 (off): the identity-swap cost of issue 27 (crossings traced); 400 with "
    "margin 0.1 behind only keeps 2 more MOT17 identities, one video's once every variant "
    "tried is chosen across folds: not kept (docs/DESIGN-NOTES.md).",
    "swap_margin": "used only with swap_weight; 0.1 chosen on the shared MOT17 sequences "
    "(docs/DESIGN-NOTES.md).",
    "swap_behind": "used only with swap_weight; measured both ways (docs/DESIGN-NOTES.md).",
    "weak_confidence": "off (None); ByteTrack's 0.1 when on, a technique measured across "
    "folds, not kept (docs/DESIGN-NOTES.md).",
    "weak_iou": "ByteTrack's second-round 0.5, used only with weak_confidence; not tuned.",
    "confidence_sigmoid": "input: the detection format (PointRCNN's logits are mapped when read).",
    "likelihood_levels": "solver resolution (speed of the worst frame), not a model parameter.",
    "decompose": "solver: exact decomposition, on for the packaged encoding.",
    "max_conflicts": "solver work budget (deterministic), not a model parameter.",
    "max_solve_ms": "solver wall-clock budget, off by default.",
    "velocity_prior": "default 3 box sizes / s, a design choice, not tuned.",
    "costs.enters": "default; calibrate estimates it as −100 ln P(begins at the border).",
    "costs.appears": "default (a first grid axis, flat: docs/DESIGN-NOTES.md); calibrate "
    "estimates it as −100 ln P(begins inside).",
    "costs.leaves": f"default (MOT 300, {_HAND}); calibrate estimates it as −100 ln P(ends "
    "at the border).",
    "costs.lost": "default; calibrate estimates it as −100 ln P(ends inside).",
    "costs.dropped": "0: dropping an unconfirmed hypothesis is free by design.",
    "costs.hides": "default, hand-chosen, not tuned.",
    "costs.missing": "default, hand-chosen, not tuned.",
    "costs.unseen": "default, hand-chosen, not tuned.",
    "costs.ignore": "default, hand-chosen, not tuned.",
    "costs.resumes": f"{_HAND} (200 in both presets).",
    "costs.returns": "used only with revive_s; below costs.enters by design, not tuned.",
    "costs.resumes_seen": "used only with resume_last_seen; measured across folds "
    "(docs/DESIGN-NOTES.md).",
    "kalman.position_std": _DEEPSORT + ".",
    "kalman.velocity_std": f"{_DEEPSORT}; KITTI 0.1, {_HAND}.",
    "kalman.measurement_std": f"{_DEEPSORT}; MOT 1/17, {_HAND}.",
    "kalman.init_position_std": _DEEPSORT + ".",
    "kalman.init_velocity_std": "set from velocity_prior / fps.",
    "kalman.min_size": "a floor against collapsing boxes, not tuned.",
    "kalman.velocity_adapt": "0 (off); adaptive velocity noise of issue 27, measured across "
    "folds, not kept (docs/DESIGN-NOTES.md).",
    "kalman.perspective": "off; the pinhole filter of issue 27, measured across folds, not "
    "kept (docs/DESIGN-NOTES.md).",
    "kalman.perspective_x": "a fact of the camera (null: the image's centre), not tuned.",
    "kalman.perspective_y": "a fact of the camera (null: the image's centre), not tuned.",
    "kalman.depth_noise": "0.1, chosen leave one video out against 1 with the pinhole filter "
    "on (docs/DESIGN-NOTES.md).",
}


def parameter_origin(key: str) -> str:
    """One line: where a parameter's value comes from (:data:`ORIGINS`)."""
    return ORIGINS.get(key, "no origin recorded (default of TrackerConfig).")


def calibrate_keys() -> tuple[str, ...]:
    """The parameters ``sensemaking calibrate`` estimates."""
    from sensemaking.calibrate import ESTIMATED

    return ESTIMATED


#: the estimates of calibrate in groups that are used one at a time (the rest at the preset) to
#: find which of them makes calibrate's cross-validated number differ from the grid's
CALIBRATE_GROUPS: dict[str, tuple[str, ...]] = {
    "thresholds": ("start_confidence", "min_confidence", "confirm_confidence"),
    "min_hits": ("min_hits",),
    "max_missing_s": ("max_missing_s",),
    "border costs": ("costs.enters", "costs.appears", "costs.leaves", "costs.lost"),
}
#: calibrate is as good as the grid (stated before it was measured): the mean over the family's
#: benchmarks of its cross-validated HOTA at most this much (fraction) below the grid's ...
CALIBRATE_MEAN_TOLERANCE = 0.003
#: ... and on most folds (more than half) its HOTA on the held-out video (mean over the
#: video's sequences) at most this much (fraction) below the grid's
CALIBRATE_FOLD_TOLERANCE = 0.001
#: the metrics kept per benchmark in the report
FIELDS = ("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDSW", "CLR_FP", "CLR_FN")
Progress = Callable[[str], None]


def family_of(spec: BenchmarkSpec) -> str:
    """The parameter family (``kitti`` / ``mot``) of a benchmark."""
    from sensemaking.settings import family_name

    return family_name(spec.family)


def fold_key(spec: BenchmarkSpec, sequence: str) -> str:
    """The video a sequence comes from: what a fold holds out (the same video seen by another
    detector or as another half is held out with it)."""
    if spec.rules == "kitti":
        return f"KITTI-{sequence}"
    m = re.match(r"(MOT\d\d-\d\d)", sequence)
    return m.group(1) if m else sequence


def grid_points(grid: Mapping[str, SequenceABC[Any]]) -> list[dict[str, Any]]:
    """Every sensible combination of the grid's values, as dotted parameter -> value (first key
    slowest). A continue threshold above the start threshold is left out: a detection could then
    start a track that the next one like it cannot continue."""
    keys = list(grid)
    points = [dict(zip(keys, values, strict=True)) for values in product(*(grid[k] for k in keys))]
    return [
        p
        for p in points
        if p.get("min_confidence", -math.inf) <= p.get("start_confidence", math.inf)
    ]


@dataclass
class FamilyCV:
    """Cross-validation of one family.

    Attributes:
        family: ``kitti`` or ``mot``.
        grid: parameter -> values tried.
        points: the grid points (dotted parameter -> value).
        benchmarks: the family's benchmarks, in report order.
        sequences: benchmark -> its sequences.
        folds: fold (video) keys, sorted.
        choice: fold -> index of the grid point chosen without it (rule ``minimax``).
        fold_objective: fold -> per grid point, the training objective without that fold.
        fold_regret: fold -> per grid point, its largest regret over the training videos.
        mean_choice, mean_heldout: the same choice and cross-validated metrics by rule ``mean``
            (the best training objective), for comparison.
        objective_all: per grid point, the training objective on every sequence (mean HOTA over
            the family's benchmarks, fractions).
        in_sample: index of the grid point with the best objective on every sequence.
        recommended: index chosen by most folds (ties: the better ``objective_all``).
        preset: index of the grid point equal to the shipped preset's values, or None.
        point_metrics: per grid point, benchmark -> combined metrics of every sequence.
        heldout, insample, preset_metrics: benchmark -> combined metrics (fractions) of the
            sequences scored with their fold's choice / with ``in_sample`` / with ``preset``.
        per_sequence: benchmark -> sequence -> {"fold", "choice", "cv", "in_sample",
            "calibrate_cv", "calibrate_in_sample"} (HOTA).
        calibrated: fold -> the values :func:`~sensemaking.calibrate.calibrate` estimated on
            the other videos (dotted keys); ``calibrated_all``: on every video.
        calibrate_heldout, calibrate_insample: benchmark -> combined metrics of the sequences
            tracked with their fold's calibrated values / with ``calibrated_all``.
        fold_hota: rule (``minimax``, ``calibrate``) -> fold -> HOTA on the held-out video
            (mean over its sequences).
        calibrate_groups: group of :data:`CALIBRATE_GROUPS` -> benchmark -> combined metrics,
            cross-validated, with only that group's estimates (the rest at the preset).
        calibrated_own, calibrate_own_heldout: calibrate *per detector*: benchmark -> fold ->
            the values estimated on the same benchmark's other videos (a benchmark of one
            video takes the family's), and benchmark -> combined metrics, cross-validated.
        seconds: wall time of the whole cross-validation.
    """

    family: str
    grid: dict[str, list[Any]]
    points: list[dict[str, Any]]
    benchmarks: list[str]
    sequences: dict[str, list[str]]
    folds: list[str]
    choice: dict[str, int] = field(default_factory=dict)
    fold_objective: dict[str, list[float]] = field(default_factory=dict)
    fold_regret: dict[str, list[float]] = field(default_factory=dict)
    mean_choice: dict[str, int] = field(default_factory=dict)
    mean_heldout: dict[str, dict[str, float]] = field(default_factory=dict)
    objective_all: list[float] = field(default_factory=list)
    in_sample: int = 0
    recommended: int = 0
    preset: int | None = None
    point_metrics: list[dict[str, dict[str, float]]] = field(default_factory=list)
    heldout: dict[str, dict[str, float]] = field(default_factory=dict)
    insample: dict[str, dict[str, float]] = field(default_factory=dict)
    preset_metrics: dict[str, dict[str, float]] = field(default_factory=dict)
    per_sequence: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)
    calibrated: dict[str, dict[str, Any]] = field(default_factory=dict)
    calibrated_all: dict[str, Any] = field(default_factory=dict)
    calibrate_heldout: dict[str, dict[str, float]] = field(default_factory=dict)
    calibrate_insample: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_hota: dict[str, dict[str, float]] = field(default_factory=dict)
    calibrate_groups: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    calibrated_own: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)
    calibrate_own_heldout: dict[str, dict[str, float]] = field(default_factory=dict)
    seconds: float = 0.0

    def gap(self, bench: str) -> float:
        """Cross-validated minus in-sample HOTA of a benchmark (fraction)."""
        return float(self.heldout[bench]["HOTA"] - self.insample[bench]["HOTA"])

    def fold_spread(self, bench: str) -> tuple[float, float]:
        """(min, max) over the benchmark's sequences of cross-validated minus in-sample HOTA."""
        diffs = [s["cv"] - s["in_sample"] for s in self.per_sequence[bench].values()]
        return (float(min(diffs)), float(max(diffs))) if diffs else (float("nan"), float("nan"))

    def choice_counts(self) -> list[tuple[int, int]]:
        """(grid point, folds that chose it), most frequent first."""
        return Counter(self.choice.values()).most_common()

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> FamilyCV:
        """The inverse of :meth:`to_json` (derived entries such as the verdict dropped)."""
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in data.items() if k in names})

    def to_json(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "grid": self.grid,
            "points": self.points,
            "benchmarks": self.benchmarks,
            "sequences": self.sequences,
            "folds": self.folds,
            "choice": self.choice,
            "fold_objective": self.fold_objective,
            "fold_regret": self.fold_regret,
            "mean_choice": self.mean_choice,
            "mean_heldout": self.mean_heldout,
            "objective_all": self.objective_all,
            "in_sample": self.in_sample,
            "recommended": self.recommended,
            "preset": self.preset,
            "point_metrics": self.point_metrics,
            "heldout": self.heldout,
            "insample": self.insample,
            "preset_metrics": self.preset_metrics,
            "per_sequence": self.per_sequence,
            "calibrated": self.calibrated,
            "calibrated_all": self.calibrated_all,
            "calibrate_heldout": self.calibrate_heldout,
            "calibrate_insample": self.calibrate_insample,
            "fold_hota": self.fold_hota,
            "calibrate_groups": self.calibrate_groups,
            "calibrated_own": self.calibrated_own,
            "calibrate_own_heldout": self.calibrate_own_heldout,
            "calibrate_verdict": calibrate_verdict(self) if self.calibrate_heldout else None,
            "seconds": self.seconds,
        }


def calibrate_verdict(cv: FamilyCV) -> dict[str, Any]:
    """Is rule ``calibrate`` as good as the grid's (``minimax``) across folds? The rule, stated
    before it was measured: the mean over the family's benchmarks of calibrate's cross-validated
    HOTA is at most :data:`CALIBRATE_MEAN_TOLERANCE` below the grid's, and on more than half of
    the folds its held-out HOTA is at most :data:`CALIBRATE_FOLD_TOLERANCE` below the grid's.

    Returns ``{"as_good", "mean_grid", "mean_calibrate", "folds_not_worse", "folds"}``.
    """
    grid = float(np.mean([cv.heldout[b]["HOTA"] for b in cv.benchmarks]))
    cal = float(np.mean([cv.calibrate_heldout[b]["HOTA"] for b in cv.benchmarks]))
    g, c = cv.fold_hota.get("minimax", {}), cv.fold_hota.get("calibrate", {})
    not_worse = sum(1 for f in cv.folds if c[f] >= g[f] - CALIBRATE_FOLD_TOLERANCE)
    return {
        "as_good": bool(cal >= grid - CALIBRATE_MEAN_TOLERANCE and 2 * not_worse > len(cv.folds)),
        "mean_grid": grid,
        "mean_calibrate": cal,
        "folds_not_worse": not_worse,
        "folds": len(cv.folds),
    }


def calibration_sequence(spec: BenchmarkSpec, seq: Any, gt: Any) -> Any:
    """The :class:`~sensemaking.calibrate.CalibrationSequence` of a benchmark sequence (its
    detections as every tracker reads them; ``gt``: its whole ground-truth file as read)."""
    from sensemaking.calibrate import annotated_sequence
    from sensemaking.classes import class_id

    return annotated_sequence(
        f"{spec.name}/{seq.name}",
        gt,
        seq.detections,
        class_id(spec.class_name or "pedestrian"),
        seq.first_frame,
        int(seq.info.length),
        float(seq.info.fps),
        (int(seq.info.width), int(seq.info.height)),
    )


def _preset_index(family: str, points: list[dict[str, Any]]) -> int | None:
    """The grid point whose values are the preset's (a value the preset leaves out is the
    default's)."""
    from sensemaking.settings import params_of, preset_config

    preset = params_of(preset_config(family))
    for i, p in enumerate(points):
        if all(preset.get(k) == v for k, v in p.items()):
            return i
    return None


def _combine(items: list[Any]) -> dict[str, float]:
    from sensemaking.evaluation.report import SequenceMetrics

    m = SequenceMetrics.combine(items)
    out = {}
    for k in FIELDS:
        if k in m:
            v = m[k]
            out[k] = int(v) if isinstance(v, (int, np.integer)) else float(v)
    return out


def _score(scores: dict[str, dict[str, Any]], seqs: Mapping[str, SequenceABC[str]]) -> float:
    """Mean over benchmarks (with at least one sequence in ``seqs``) of their combined HOTA."""
    values = [
        _combine([scores[b][s] for s in names])["HOTA"] for b, names in seqs.items() if names
    ]
    return float(np.mean(values)) if values else float("nan")


def cross_validate(
    benches: SequenceABC[Benchmark],
    output_dir: Path,
    grid: Mapping[str, SequenceABC[Any]] | None = None,
    progress: Progress | None = None,
    groups: bool = False,
    per_detector: bool = True,
) -> FamilyCV:
    """Leave-one-video-out cross-validation over ``grid`` on the benchmarks of one family.

    Result files go to ``output_dir/crossval/<benchmark>/p<point>/<sequence>.txt`` and, scored
    with their fold's choice, ``output_dir/crossval/<benchmark>/heldout/<sequence>.txt``; rule
    ``calibrate``'s to ``calibrate/`` (cross-validated), ``calibrate-all/`` (in-sample), with
    ``per_detector`` to ``calibrate-own/`` (each benchmark calibrated on its own other videos)
    and with ``groups`` to ``calibrate-<group>/`` (one group of estimates at a time: four more
    passes, off by default to keep the benchmark run short; docs/DESIGN-NOTES.md has a run).
    """
    from sensemaking.evaluation import evaluate_sequence
    from sensemaking.settings import apply_settings

    start = time.perf_counter()
    say = progress or (lambda msg: None)
    if not benches:
        raise ValueError("no benchmark to cross-validate")
    family = family_of(benches[0].spec)
    grid = dict(GRID[family] if grid is None else grid)
    points = grid_points(grid)
    cv = FamilyCV(
        family=family,
        grid={k: list(v) for k, v in grid.items()},
        points=points,
        benchmarks=[b.spec.name for b in benches],
        sequences={b.spec.name: [s.name for s in b.sequences] for b in benches},
        folds=[],
    )
    fold_of = {
        (b.spec.name, s.name): fold_key(b.spec, s.name) for b in benches for s in b.sequences
    }
    cv.folds = sorted(set(fold_of.values()))
    if len(cv.folds) < 2:
        raise ValueError(f"cross-validation needs two videos or more, got {cv.folds}")
    cv.preset = _preset_index(family, points)
    gts = {b.spec.name: {s.name: read_gt(b.spec, s.gt_path) for s in b.sequences} for b in benches}
    frames = {
        (b.spec.name, s.name): dict(s.detections.frames()) for b in benches for s in b.sequences
    }
    # scores[point][benchmark][sequence] -> SequenceMetrics
    scores: list[dict[str, dict[str, Any]]] = []
    root = output_dir / "crossval"

    def track_and_score(b: Benchmark, s: Any, params: Mapping[str, Any], path: Path) -> Any:
        spec = b.spec
        base = ours_config(spec.family, fps=s.info.fps, image_size=(s.info.width, s.info.height))
        tracker = OursAdapter(name="ours", config=apply_settings(base, params), states=(0,))
        tracks, _ = run_sequence(tracker, s, frames[(spec.name, s.name)])
        write_results(spec, path, tracks)
        return evaluate_sequence(
            gts[spec.name][s.name],
            read_results(spec, path),
            rules_name(spec),
            n_frames=int(s.info.length),
            name=s.name,
            gt_path=s.gt_path,
            tracks_path=path,
        )

    for i, point in enumerate(points):
        per_bench: dict[str, dict[str, Any]] = {}
        for b in benches:
            per_bench[b.spec.name] = {
                s.name: track_and_score(
                    b, s, point, root / b.spec.name / f"p{i:02d}" / f"{s.name}.txt"
                )
                for s in b.sequences
            }
        scores.append(per_bench)
        cv.point_metrics.append(
            {b: _combine([per_bench[b][s] for s in names]) for b, names in cv.sequences.items()}
        )
        everything = {b.spec.name: [s.name for s in b.sequences] for b in benches}
        cv.objective_all.append(_score(per_bench, everything))
        say(
            f"[crossval {family}] grid point {i + 1}/{len(points)} "
            f"{', '.join(f'{k}={v}' for k, v in point.items())}: "
            f"mean HOTA {100 * cv.objective_all[-1]:.2f}"
        )
    cv.in_sample = int(np.argmax(cv.objective_all))
    # per video and grid point: mean over benchmarks of the HOTA of the video's sequences
    per_video = np.array(
        [
            [
                float(
                    np.mean(
                        [
                            scores[i][b.spec.name][s.name]["HOTA"]
                            for b in benches
                            for s in b.sequences
                            if fold_of[(b.spec.name, s.name)] == v
                        ]
                    )
                )
                for v in cv.folds
            ]
            for i in range(len(points))
        ]
    )
    regret = per_video.max(axis=0, keepdims=True) - per_video  # (points, videos)
    for k, fold in enumerate(cv.folds):
        train = {
            b.spec.name: [s.name for s in b.sequences if fold_of[(b.spec.name, s.name)] != fold]
            for b in benches
        }
        objective = [_score(scores[i], train) for i in range(len(points))]
        worst = np.delete(regret, k, axis=1).max(axis=1)
        cv.fold_objective[fold] = objective
        cv.fold_regret[fold] = worst.tolist()
        cv.mean_choice[fold] = int(np.nanargmax(objective))
        # least worst regret; ties: the better objective, then the earlier point
        cv.choice[fold] = min(
            range(len(points)), key=lambda i: (round(float(worst[i]), 12), -objective[i], i)
        )
    counts = Counter(cv.choice.values())
    cv.recommended = max(counts, key=lambda i: (counts[i], cv.objective_all[i]))
    # rule calibrate: estimated on the other videos, every benchmark of the family pooled
    from sensemaking.calibrate import calibrate
    from sensemaking.errors import InputError

    annotated = {
        (b.spec.name, s.name): calibration_sequence(b.spec, s, gts[b.spec.name][s.name])
        for b in benches
        for s in b.sequences
    }
    cv.calibrated_all = calibrate(list(annotated.values())).params
    for fold in cv.folds:
        training = [a for key, a in annotated.items() if fold_of[key] != fold]
        cv.calibrated[fold] = calibrate(training).params
    cal_scores: dict[str, dict[str, dict[str, Any]]] = {"cv": {}, "in_sample": {}}
    for b in benches:
        name = b.spec.name
        cal_scores["cv"][name] = {
            s.name: track_and_score(
                b,
                s,
                cv.calibrated[fold_of[(name, s.name)]],
                root / name / "calibrate" / f"{s.name}.txt",
            )
            for s in b.sequences
        }
        cal_scores["in_sample"][name] = {
            s.name: track_and_score(
                b, s, cv.calibrated_all, root / name / "calibrate-all" / f"{s.name}.txt"
            )
            for s in b.sequences
        }
    # calibrate per detector: the same benchmark's other videos only, as a user calibrates their
    # own detector (a benchmark of one video, or without the class elsewhere: the family's)
    for b in benches if per_detector else ():
        name = b.spec.name
        cv.calibrated_own[name] = {}
        results = []
        for s in b.sequences:
            fold = fold_of[(name, s.name)]
            own = [
                annotated[(name, o.name)] for o in b.sequences if fold_of[(name, o.name)] != fold
            ]
            try:
                params = calibrate(own).params if own else cv.calibrated[fold]
            except InputError:
                params = cv.calibrated[fold]
            cv.calibrated_own[name][fold] = params
            results.append(
                track_and_score(b, s, params, root / name / "calibrate-own" / f"{s.name}.txt")
            )
        cv.calibrate_own_heldout[name] = _combine(results)
        say(
            f"[crossval {family}] {name}, calibrate per detector: cross-validated HOTA "
            f"{100 * cv.calibrate_own_heldout[name]['HOTA']:.2f}"
        )
    for group, keys in CALIBRATE_GROUPS.items() if groups else ():
        folder = "calibrate-" + group.replace(" ", "-")
        cv.calibrate_groups[group] = {}
        for b in benches:
            name = b.spec.name
            cv.calibrate_groups[group][name] = _combine(
                [
                    track_and_score(
                        b,
                        s,
                        {
                            k: v
                            for k, v in cv.calibrated[fold_of[(name, s.name)]].items()
                            if k in keys
                        },
                        root / name / folder / f"{s.name}.txt",
                    )
                    for s in b.sequences
                ]
            )
        say(
            f"[crossval {family}] calibrate, only {group}: cross-validated HOTA "
            + ", ".join(
                f"{b} {100 * m['HOTA']:.2f}" for b, m in cv.calibrate_groups[group].items()
            )
        )
    say(
        f"[crossval {family}] calibrate on every video: "
        f"{', '.join(f'{k}={v}' for k, v in cv.calibrated_all.items())}"
    )
    for rule in ("minimax", "calibrate"):
        cv.fold_hota[rule] = {}
        for fold in cv.folds:
            values = [
                float(
                    (
                        scores[cv.choice[fold]][b.spec.name][s.name]
                        if rule == "minimax"
                        else cal_scores["cv"][b.spec.name][s.name]
                    )["HOTA"]
                )
                for b in benches
                for s in b.sequences
                if fold_of[(b.spec.name, s.name)] == fold
            ]
            cv.fold_hota[rule][fold] = float(np.mean(values))
    for b in benches:
        name = b.spec.name
        chosen = {s.name: cv.choice[fold_of[(name, s.name)]] for s in b.sequences}
        cv.heldout[name] = _combine([scores[chosen[s.name]][name][s.name] for s in b.sequences])
        cv.mean_heldout[name] = _combine(
            [scores[cv.mean_choice[fold_of[(name, s.name)]]][name][s.name] for s in b.sequences]
        )
        cv.insample[name] = _combine([scores[cv.in_sample][name][s.name] for s in b.sequences])
        if cv.preset is not None:
            cv.preset_metrics[name] = _combine(
                [scores[cv.preset][name][s.name] for s in b.sequences]
            )
        cv.calibrate_heldout[name] = _combine(
            [cal_scores["cv"][name][s.name] for s in b.sequences]
        )
        cv.calibrate_insample[name] = _combine(
            [cal_scores["in_sample"][name][s.name] for s in b.sequences]
        )
        cv.per_sequence[name] = {
            s.name: {
                "fold": fold_of[(name, s.name)],
                "choice": chosen[s.name],
                "cv": float(scores[chosen[s.name]][name][s.name]["HOTA"]),
                "in_sample": float(scores[cv.in_sample][name][s.name]["HOTA"]),
                "calibrate_cv": float(cal_scores["cv"][name][s.name]["HOTA"]),
                "calibrate_in_sample": float(cal_scores["in_sample"][name][s.name]["HOTA"]),
            }
            for s in b.sequences
        }
        heldout_dir = root / name / "heldout"
        heldout_dir.mkdir(parents=True, exist_ok=True)
        for s in b.sequences:
            src = root / name / f"p{chosen[s.name]:02d}" / f"{s.name}.txt"
            (heldout_dir / f"{s.name}.txt").write_bytes(src.read_bytes())
        say(
            f"[crossval {family}] {name}: "
            f"cross-validated HOTA {100 * cv.heldout[name]['HOTA']:.2f}, "
            f"in-sample {100 * cv.insample[name]['HOTA']:.2f}; calibrate: cross-validated "
            f"{100 * cv.calibrate_heldout[name]['HOTA']:.2f}, "
            f"in-sample {100 * cv.calibrate_insample[name]['HOTA']:.2f}"
        )
    cv.seconds = time.perf_counter() - start
    return cv

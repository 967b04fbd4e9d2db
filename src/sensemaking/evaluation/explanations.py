"""Are the tracker's explanations true? Events and warnings checked against ground truth.

For every abduced event (``hides_behind``, ``unhides_from_behind``, ``enters_fov``,
``leaves_fov``, ``starts``, ``ends``, ``missing_detections``, ``reappears``, and a revived
track's ``reenters_fov`` / ``returns``) and every
HIDDEN_ENTITY / SUDDEN_STOP / OVERTAKING warning, a verdict: ``plausible``, ``implausible`` or
``undecidable``, with the reason. The method and every threshold are in docs/EXPLANATIONS.md::

    from sensemaking.evaluation.explanations import GroundTruth, evaluate_explanations

    truth = GroundTruth.from_kitti(labels, image_size=(1242, 375), fps=10.0, classes=("car",))
    result = evaluate_explanations(truth, tracks, events, warnings)
    result.summary()          # per event kind: counts, precision, reasons
    print(explanation_table({"kitti-rrc-car": [result]}))

A track is identified with a ground-truth object frame by frame by the evaluation package's own
matching (IoU >= 0.5, Hungarian per frame: :func:`match_tracks`); ``tracks`` are the boxes the
tracker output as visible (the ``track`` results file without ``--write-hidden``).
"""

from __future__ import annotations

import bisect
import logging
import math
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from functools import partial
from typing import Any

import numpy as np

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.evaluation._prepare import (
    EPS,
    conflict_frames,
    max_assignment,
    offsets,
    overlap_pairs,
)
from sensemaking.records import event_record, judged_warnings, read_events, read_warnings
from sensemaking.results import Event
from sensemaking.vocabulary import START_EVENTS

__all__ = [
    "ExplanationConfig",
    "GroundTruth",
    "Verdict",
    "WarningVerdict",
    "ExplanationResult",
    "match_tracks",
    "evaluate_explanations",
    "load_ground_truth",
    "explanation_table",
    "confidence_table",
    "confidence_text",
    "spread_table",
    "CONFIDENCE_THRESHOLDS",
    "late_start_events",
    "judged_warnings",
    "read_events",
    "read_warnings",
    "EVENT_KINDS",
    "PLAUSIBLE",
    "IMPLAUSIBLE",
    "UNDECIDABLE",
]

log = logging.getLogger(__name__)

PLAUSIBLE, IMPLAUSIBLE, UNDECIDABLE = "plausible", "implausible", "undecidable"
#: event kinds judged, in table order
EVENT_KINDS = (
    "hides_behind",
    "may_hide_behind",
    "unhides_from_behind",
    "enters_fov",
    "leaves_fov",
    "starts",
    "ends",
    "missing_detections",
    "reappears",
    "reenters_fov",
    "returns",
)
#: the events that say a track hides behind another (judged alike); ``may_hide_behind`` is a
#: late hiding of a track already unobserved, said apart for its weaker evidence
_HIDING_KINDS = ("hides_behind", "may_hide_behind")
#: warnings judged
WARNING_KINDS = ("HIDDEN_ENTITY", "SUDDEN_STOP", "OVERTAKING")


@dataclass(frozen=True)
class ExplanationConfig:
    """Thresholds of the judgement (docs/EXPLANATIONS.md says why each value).

    Attributes:
        iou_threshold: IoU for a track box to match a ground-truth box (the CLEAR MOT 0.5).
        border_margin_px: a ground-truth box within this many pixels of the image edge (or a
            KITTI box with ``truncated`` > 0) is *at the border*.
        kitti_occluded_min: KITTI ``occluded`` level from which an object counts as occluded
            (0 fully visible, 1 partly, 2 largely occluded, 3 unknown).
        kitti_visible_max: KITTI level up to which an object counts as visible again (HIDDEN_ENTITY
            reappearance: a partly occluded object is what a detector sees).
        visibility_max: MOT17 visibility ratio below which a pedestrian counts as occluded
            (and from which on it counts as visible again).
        min_cover: fraction of the hidden object's ground-truth box the occluder's box must cover.
        window_s: tolerance (seconds) between an enter/leave/start/end event and the ground-truth
            track's first/last frame at the border.
        reappear_frames, reappear_px: a HIDDEN_ENTITY prediction is *on target* when the object
            reappears within this many frames of the predicted frame and this many pixels of the
            predicted bottom centre.
        lane_half_width_m: KITTI: an object with ``|X|`` up to this (metres) is in the ego lane.
        ttc_max_s: SUDDEN_STOP is plausible when the ground-truth time to contact is at most this.
        ttc_span_s: closing speed for the time to contact: depth change over this time span.
        min_side_m: OVERTAKING: lateral distance (metres) between the two vehicles' centres from
            which they are side by side, i.e. in different lanes.
    """

    iou_threshold: float = 0.5
    border_margin_px: float = 10.0
    kitti_occluded_min: int = 1
    kitti_visible_max: int = 1
    visibility_max: float = 0.5
    min_cover: float = 0.1
    window_s: float = 1.0
    reappear_frames: int = 3
    reappear_px: float = 50.0
    lane_half_width_m: float = 2.0
    ttc_max_s: float = 4.0
    ttc_span_s: float = 0.5
    min_side_m: float = 1.0

    def __post_init__(self) -> None:
        if not 0.0 < self.iou_threshold <= 1.0:
            raise ValueError(f"iou_threshold must be in (0, 1], got {self.iou_threshold}")
        for name in (
            "border_margin_px",
            "min_cover",
            "window_s",
            "reappear_px",
            "lane_half_width_m",
            "ttc_max_s",
            "ttc_span_s",
            "min_side_m",
        ):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {getattr(self, name)!r}")


# -- ground truth ---------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class GroundTruth:
    """One sequence's ground truth, as the judgement needs it.

    Attributes:
        boxes: every labelled object (``tracker_id`` = object id, frame, ``xyxy`` pixels);
            ``data``: ``occluded``/``truncated``/``location`` (KITTI) or ``visibility`` (MOT).
        matchable: (N,) bool, rows a track may be matched to (the evaluated class and its
            distractors: KITTI Car+Van or Pedestrian+Person_sitting, MOT17 pedestrians and
            the person-like distractor classes, MOT15 all).
        kind: ``"kitti"`` (occlusion level, 3D position), ``"mot"`` (visibility ratio) or
            ``"boxes"`` (boxes only: MOT15, occlusion undecidable).
        image_size: (width, height) pixels. fps: frames per second.
        first_frame, n_frames: the sequence's frames ``first_frame .. first_frame + n_frames - 1``.
    """

    boxes: Detections
    matchable: np.ndarray
    kind: str
    image_size: tuple[int, int]
    fps: float
    first_frame: int
    n_frames: int

    @classmethod
    def from_kitti(
        cls,
        labels: Detections,
        *,
        image_size: tuple[int, int],
        fps: float = 10.0,
        classes: Sequence[str] = ("car",),
        n_frames: int | None = None,
    ) -> GroundTruth:
        """KITTI ``label_02`` rows (``io.kitti.read_kitti_labels``); DontCare rows are dropped.
        ``classes``: the tracked classes (``car`` matches Car and Van, ``pedestrian``
        Pedestrian and Person_sitting)."""
        # Detections fills every column on construction
        assert labels.tracker_id is not None and labels.class_id is not None
        keep = (labels.tracker_id >= 0) & (labels.class_id != CLASS_IDS["dontcare"])
        boxes = labels[keep]
        wanted: set[int] = set()
        for c in classes:
            c = c.strip().lower()
            if c == "car":
                wanted |= {CLASS_IDS["car"], CLASS_IDS["van"]}
            elif c == "pedestrian":
                wanted |= {CLASS_IDS["pedestrian"], CLASS_IDS["person_sitting"]}
            elif c in CLASS_IDS:
                wanted.add(CLASS_IDS[c])
            else:
                raise ValueError(f"unknown class {c!r}")
        assert boxes.class_id is not None
        return cls._make(
            boxes, np.isin(boxes.class_id, sorted(wanted)), "kitti", image_size, fps, 0, n_frames
        )

    @classmethod
    def from_mot(
        cls,
        gt: Detections,
        *,
        image_size: tuple[int, int],
        fps: float = 30.0,
        n_frames: int | None = None,
    ) -> GroundTruth:
        """MOTChallenge ``gt.txt`` rows (``io.mot.read_mot(kind="gt")``). With a visibility column
        (MOT16/17/20) pedestrians and person-like distractors are matchable; without (MOT15,
        visibility -1) every row with a non-zero consider flag is."""
        vis = np.asarray(gt.data.get("visibility", np.full(len(gt), -1.0)), dtype=np.float64)
        has_vis = bool(len(gt)) and bool((vis >= 0).any())
        if has_vis:
            person = [
                CLASS_IDS[n]
                for n in (
                    "pedestrian",
                    "person_on_vehicle",
                    "static_person",
                    "distractor",
                    "reflection",
                )
            ]
            assert gt.class_id is not None  # Detections fills every column on construction
            matchable = np.isin(gt.class_id, person)
        else:
            consider = np.asarray(gt.data.get("consider", np.ones(len(gt))))
            matchable = consider != 0
        return cls._make(
            gt, matchable, "mot" if has_vis else "boxes", image_size, fps, 1, n_frames
        )

    @classmethod
    def _make(
        cls,
        boxes: Detections,
        matchable: np.ndarray,
        kind: str,
        image_size: tuple[int, int],
        fps: float,
        first: int,
        n_frames: int | None,
    ) -> GroundTruth:
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        if n_frames is None:
            assert boxes.frame is not None  # Detections fills every column on construction
            n_frames = int(boxes.frame.max()) - first + 1 if len(boxes) else 0
        return cls(
            boxes,
            np.asarray(matchable, dtype=bool),
            kind,
            (int(image_size[0]), int(image_size[1])),
            float(fps),
            first,
            int(n_frames),
        )


class _Truth:
    """Lookups over a :class:`GroundTruth`: rows by (object, frame), frames by object."""

    def __init__(self, gt: GroundTruth, config: ExplanationConfig):
        self.gt, self.c = gt, config
        b = gt.boxes
        assert b.tracker_id is not None and b.frame is not None  # filled on construction
        self.row: dict[tuple[int, int], int] = {}
        frames: dict[int, list[int]] = defaultdict(list)
        for i, (g, f) in enumerate(zip(b.tracker_id.tolist(), b.frame.tolist(), strict=True)):
            self.row[(g, f)] = i
            frames[g].append(f)
        self.frames = {g: sorted(fs) for g, fs in frames.items()}
        self.xyxy = b.xyxy
        w, h = gt.image_size
        m = config.border_margin_px
        at = (
            (b.xyxy[:, 0] <= m)
            | (b.xyxy[:, 1] <= m)
            | (b.xyxy[:, 2] >= w - m)
            | (b.xyxy[:, 3] >= h - m)
        )
        if "truncated" in b.data:
            at |= np.asarray(b.data["truncated"], dtype=np.float64) > 0
        self.at_border = at
        self.occl = np.asarray(b.data["occluded"], dtype=np.int64) if gt.kind == "kitti" else None
        self.vis = np.asarray(b.data["visibility"], dtype=np.float64) if gt.kind == "mot" else None
        self.loc = np.asarray(b.data["location"], dtype=np.float64) if gt.kind == "kitti" else None
        # half the object's extent along the camera axis: contact is with its near face, not
        # its centre (KITTI rotation_y 0 faces along x: a car ahead, ry = -pi/2, shows l / 2)
        self.half_depth: np.ndarray | None = None
        if self.loc is not None and "dimensions" in b.data and "rotation_y" in b.data:
            hwl = np.asarray(b.data["dimensions"], dtype=np.float64).reshape(-1, 3)
            ry = np.asarray(b.data["rotation_y"], dtype=np.float64)
            half = (hwl[:, 2] * np.abs(np.sin(ry)) + hwl[:, 1] * np.abs(np.cos(ry))) / 2
            self.half_depth = np.where(np.isfinite(half) & (hwl[:, 2] > 0), half, 0.0)

    def occluded(self, i: int) -> bool | None:
        """Row ``i`` is occluded per the ground truth (None: the ground truth cannot say)."""
        if self.occl is not None:
            return bool(self.occl[i] >= self.c.kitti_occluded_min)
        if self.vis is not None:
            return bool(self.vis[i] < self.c.visibility_max)
        return None

    def visible(self, i: int) -> bool:
        """Row ``i`` is visible enough to be detected (HIDDEN_ENTITY reappearance)."""
        if self.occl is not None:
            return bool(self.occl[i] <= self.c.kitti_visible_max)
        if self.vis is not None:
            return bool(self.vis[i] >= self.c.visibility_max)
        return True

    def last_before(self, g: int, f: int) -> int | None:
        """The latest frame <= f where object ``g`` is labelled."""
        fs = self.frames.get(g, [])
        k = bisect.bisect_right(fs, f)
        return fs[k - 1] if k else None

    def first_after(self, g: int, f: int) -> int | None:
        """The earliest frame >= f where object ``g`` is labelled."""
        fs = self.frames.get(g, [])
        k = bisect.bisect_left(fs, f)
        return fs[k] if k < len(fs) else None


# -- matching -------------------------------------------------------------------------------------
def match_tracks(
    gt: Detections, tracks: Detections, threshold: float = 0.5
) -> dict[tuple[int, int], int]:
    """``(track id, frame) -> ground-truth object id`` by the evaluation's matching: per frame, the
    Hungarian assignment maximising IoU among pairs with IoU >= ``threshold`` (TrackEval's
    preprocessing match, :func:`~sensemaking.evaluation._prepare.max_assignment`)."""
    if not len(gt) or not len(tracks):
        return {}
    # Detections fills every column on construction
    assert gt.frame is not None and gt.tracker_id is not None
    assert tracks.frame is not None and tracks.tracker_id is not None
    first = int(min(gt.frame.min(), tracks.frame.min()))
    n = int(max(gt.frame.max(), tracks.frame.max())) - first + 1
    go = np.argsort(gt.frame, kind="stable")
    to = np.argsort(tracks.frame, kind="stable")
    g_off = offsets(gt.frame[go] - first, n)
    t_off = offsets(tracks.frame[to] - first, n)
    ps, sim = overlap_pairs(gt.xyxy[go], g_off, tracks.xyxy[to], t_off, "iou")
    score = np.where(sim < threshold - EPS, 0.0, sim)
    positive = score > EPS
    chosen = max_assignment(ps, score, positive, conflict_frames(ps, positive))
    g_ids, t_ids = gt.tracker_id[go][ps.pa[chosen]], tracks.tracker_id[to][ps.pb[chosen]]
    frames = tracks.frame[to][ps.pb[chosen]]
    return {
        (int(t), int(f)): int(g)
        for t, f, g in zip(t_ids.tolist(), frames.tolist(), g_ids.tolist(), strict=True)
    }


# -- verdicts -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Verdict:
    """The judgement of one event.

    Attributes:
        event: the judged event. verdict: plausible / implausible / undecidable.
        reason: one word saying why (see docs/EXPLANATIONS.md, e.g. ``occluded_in_front``,
            ``self``, ``occluder_behind``, ``not_occluded``, ``left_view``, ``unmatched``).
        gt: ground-truth object ids of the event's arguments (None: no match).
        border: the hidden/leaving track's last box touches the image border (hides_behind).
        identity: hides_behind only: after ``unhides_from_behind``, ``kept`` / ``switched`` /
            ``unknown``, or ``not_resumed``.
    """

    event: Event
    verdict: str
    reason: str
    gt: tuple[int | None, ...] = ()
    border: bool = False
    identity: str | None = None

    def to_json(self) -> dict[str, Any]:
        out = {
            **event_record(self.event),
            "verdict": self.verdict,
            "reason": self.reason,
            "gt": list(self.gt),
        }
        if self.event.name in _HIDING_KINDS:
            out.update(border=self.border, identity=self.identity)
        return out


@dataclass(frozen=True)
class WarningVerdict:
    """The judgement of one HIDDEN_ENTITY, SUDDEN_STOP or OVERTAKING warning.

    Attributes:
        frame, situation, objects: the warning's. verdict, reason: as for events.
        gt: ground-truth id of the first object (None: no match).
        HIDDEN_ENTITY: ``reappeared`` (within the sequence), ``frame_error`` (ground-truth
        reappearance frame minus the predicted one), ``px_error`` (predicted bottom centre to the
        ground-truth one there), ``lead_frames`` (ground-truth reappearance minus the warning's
        frame), ``in_lane`` (KITTI: |X| <= lane half width there).
        SUDDEN_STOP: ``ttc_s`` (ground-truth time to contact, inf when not closing), ``lateral_m``
        (|X|), ``warned_ttc_s`` (the warning's own estimate, if any).
        OVERTAKING: ``lateral_m`` (|X_A - X_B| now).
        confidence: the warning's own (0..1), None where it states none.
    """

    frame: int
    situation: str
    objects: tuple[int, ...]
    verdict: str
    reason: str
    gt: int | None = None
    reappeared: bool | None = None
    frame_error: int | None = None
    px_error: float | None = None
    lead_frames: int | None = None
    in_lane: bool | None = None
    ttc_s: float | None = None
    lateral_m: float | None = None
    warned_ttc_s: float | None = None
    confidence: float | None = None

    @property
    def on_target(self) -> bool:
        """HIDDEN_ENTITY: reappeared within the frame and pixel tolerances (verdict plausible)."""
        return self.situation == "HIDDEN_ENTITY" and self.verdict == PLAUSIBLE

    def to_json(self) -> dict[str, Any]:
        out = asdict(self)
        out["objects"] = list(self.objects)
        if out.get("ttc_s") is not None and not math.isfinite(out["ttc_s"]):
            out["ttc_s"] = None  # JSON has no infinity: not closing
        return {k: v for k, v in out.items() if v is not None}


@dataclass
class ExplanationResult:
    """Every verdict of one (or several, when combined) sequences.

    Attributes:
        name: sequence name. events: one :class:`Verdict` per judged event. warnings: one
        :class:`WarningVerdict` per judged warning. late_starts / starts_total: ``starts`` and
        ``enters_fov`` events dated before the first frame their track is output, and all of them.
        recall: per event kind, ``(explained, occasions)`` in the ground truth (see
        docs/EXPLANATIONS.md).
        occlusions_said: the ``hides_behind`` recall occasions by what the tracker said at
        them: ``hides_behind`` (the explained ones), ``leaves_fov``, ``missing_detections``,
        ``ends`` or ``nothing``.
        hide_hit_confidence: the confidence of the ``hides_behind`` event of each explained
        recall occasion (1.0 for an event without one), for recall against a threshold.
    """

    name: str
    events: list[Verdict] = field(default_factory=list)
    warnings: list[WarningVerdict] = field(default_factory=list)
    late_starts: int = 0
    starts_total: int = 0
    recall: dict[str, tuple[int, int]] = field(default_factory=dict)
    occlusions_said: dict[str, int] = field(default_factory=dict)
    hide_hit_confidence: list[float] = field(default_factory=list)

    @classmethod
    def combine(
        cls, results: Iterable[ExplanationResult], name: str = "COMBINED"
    ) -> ExplanationResult:
        out = cls(name)
        for r in results:
            out.events += r.events
            out.warnings += r.warnings
            out.late_starts += r.late_starts
            out.starts_total += r.starts_total
            for k, (a, b) in r.recall.items():
                x, y = out.recall.get(k, (0, 0))
                out.recall[k] = (x + a, y + b)
            for k, n in r.occlusions_said.items():
                out.occlusions_said[k] = out.occlusions_said.get(k, 0) + n
            out.hide_hit_confidence += r.hide_hit_confidence
        return out

    def summary(self) -> dict[str, Any]:
        """Per event kind and warning kind: counts per verdict, precision (plausible of the
        decidable), plausible of all, reasons; plus the special counts of docs/EXPLANATIONS.md."""
        out: dict[str, Any] = {"events": {}, "warnings": {}}
        for kind in EVENT_KINDS:
            vs = [v for v in self.events if v.event.name == kind]
            row = _counts(vs)
            if kind in self.recall:
                hit, total = self.recall[kind]
                row["recall"] = hit / total if total else None
                row["recall_occasions"] = total
            if kind in _HIDING_KINDS:
                row["self"] = sum(v.reason == "self" for v in vs)
                row["implausible_at_border"] = sum(
                    v.verdict == IMPLAUSIBLE and v.border for v in vs
                )
                if kind in self.recall:
                    row["occlusions_said"] = {
                        k: self.occlusions_said.get(k, 0) for k in _SAID_KINDS
                    }
                occasions = self.recall.get(kind, (0, 0))[1]
                hits = self.hide_hit_confidence if kind == "hides_behind" else []
                row["by_confidence"] = confidence_table(vs, hits, occasions)
                ident = Counter(v.identity for v in vs)
                row["identity"] = {
                    k: ident.get(k, 0) for k in ("kept", "switched", "unknown", "not_resumed")
                }
            out["events"][kind] = row
        for kind in WARNING_KINDS:
            ws = [w for w in self.warnings if w.situation == kind]
            row = _counts(ws)
            if kind == "HIDDEN_ENTITY":
                back = [w for w in ws if w.reappeared]
                row["reappeared"] = len(back)
                row["never_reappeared"] = sum(w.reappeared is False for w in ws)
                row["on_target"] = sum(w.on_target for w in ws)
                row["on_target_of_reappeared"] = (row["on_target"] / len(back)) if back else None
                row["median_frame_error"] = _median(
                    [abs(w.frame_error) for w in back if w.frame_error is not None]
                )
                row["median_px_error"] = _median(
                    [w.px_error for w in back if w.px_error is not None]
                )
                row["median_lead_frames"] = _median(
                    [w.lead_frames for w in back if w.lead_frames is not None]
                )
                lanes = [w.in_lane for w in back if w.in_lane is not None]
                row["in_lane"] = sum(lanes) if lanes else None
            if any(w.confidence is not None for w in ws):
                # recall: of the right warnings (plausible, every confidence), those kept
                right = [_confidence(w) for w in ws if w.verdict == PLAUSIBLE]
                row["by_confidence"] = confidence_table(ws, right, len(right))
            out["warnings"][kind] = row
        out["late_starts"] = self.late_starts
        out["starts_total"] = self.starts_total
        return out


#: the thresholds of the ``hides_behind`` precision-recall table (event confidence, 0..1)
CONFIDENCE_THRESHOLDS = (0.0, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)


def _confidence(v: Verdict | WarningVerdict) -> float:
    """An event's or a warning's confidence; 1.0 where it states none."""
    level = v.confidence if isinstance(v, WarningVerdict) else v.event.confidence
    return 1.0 if level is None else float(level)


def confidence_table(
    verdicts: Sequence[Verdict] | Sequence[WarningVerdict],
    hit_confidence: Sequence[float],
    occasions: int,
    thresholds: Sequence[float] = CONFIDENCE_THRESHOLDS,
) -> list[dict[str, Any]]:
    """Precision and recall of the events (or warnings) whose confidence is at least each
    threshold.

    Per threshold: ``n`` kept, their ``plausible`` / ``implausible`` counts, ``precision``
    (plausible of the decidable, None without any) and ``recall`` (of ``occasions``, those whose
    ``hit_confidence`` reaches the threshold; None without occasions: for events the recall
    occasions explained by a kept event, for warnings the plausible warnings kept). A user who
    keeps only what is at or above a threshold gets these figures."""
    out = []
    eps = 1e-9  # confidences are written with 3 decimals
    for thr in thresholds:
        kept = [v for v in verdicts if _confidence(v) >= thr - eps]
        c = Counter(v.verdict for v in kept)
        p, i = c.get(PLAUSIBLE, 0), c.get(IMPLAUSIBLE, 0)
        hits = sum(x >= thr - eps for x in hit_confidence)
        out.append(
            {
                "threshold": thr,
                "n": len(kept),
                PLAUSIBLE: p,
                IMPLAUSIBLE: i,
                "precision": p / (p + i) if p + i else None,
                "recall": hits / occasions if occasions else None,
            }
        )
    return out


def _median(xs: list[float] | list[int]) -> float | None:
    return float(np.median(xs)) if xs else None


def _counts(vs: Sequence[Verdict] | Sequence[WarningVerdict]) -> dict[str, Any]:
    c = Counter(v.verdict for v in vs)
    p, i, u = c.get(PLAUSIBLE, 0), c.get(IMPLAUSIBLE, 0), c.get(UNDECIDABLE, 0)
    reasons = Counter(f"{v.verdict}:{v.reason}" for v in vs)
    return {
        "total": len(vs),
        PLAUSIBLE: p,
        IMPLAUSIBLE: i,
        UNDECIDABLE: u,
        "precision": p / (p + i) if p + i else None,
        "plausible_of_all": p / len(vs) if vs else None,
        "reasons": dict(sorted(reasons.items())),
    }


# -- the judge ------------------------------------------------------------------------------------
class _Evidence:
    """What every judgement looks up: the ground truth, the tracks' visible frames and boxes, and
    their frame-by-frame matching to the ground truth (done once per sequence)."""

    def __init__(self, gt: GroundTruth, tracks: Detections, config: ExplanationConfig):
        self.c = config
        self.t = _Truth(gt, config)
        self.gt = gt
        self.window = max(1, int(round(config.window_s * gt.fps)))
        sel = gt.boxes[gt.matchable]
        self.match = match_tracks(sel, tracks, config.iou_threshold)
        self.visible: dict[int, list[int]] = defaultdict(list)
        self.box: dict[tuple[int, int], np.ndarray] = {}
        assert tracks.tracker_id is not None and tracks.frame is not None  # filled on construction
        for i, (tid, f) in enumerate(
            zip(tracks.tracker_id.tolist(), tracks.frame.tolist(), strict=True)
        ):
            self.visible[tid].append(f)
            self.box[(tid, f)] = tracks.xyxy[i]
        for fs in self.visible.values():
            fs.sort()

    # track helpers
    def last_visible(self, t: int | None, f: int, inclusive: bool = False) -> int | None:
        fs = [] if t is None else self.visible.get(t, [])
        k = bisect.bisect_right(fs, f) if inclusive else bisect.bisect_left(fs, f)
        return fs[k - 1] if k else None

    def first_visible(self, t: int, f: int) -> int | None:
        fs = self.visible.get(t, [])
        k = bisect.bisect_left(fs, f)
        return fs[k] if k < len(fs) else None

    def gt_before(
        self, t: int | None, f: int, inclusive: bool = False
    ) -> tuple[int | None, int | None]:
        """(object, frame) of ``t``'s last visible box before ``f``, matched or not (None)."""
        fv = self.last_visible(t, f, inclusive)
        return (None, None) if t is None or fv is None else (self.match.get((t, fv)), fv)

    def gt_from(self, t: int | None, f: int) -> tuple[int | None, int | None]:
        """(object, frame) of ``t`` at its first matched visible frame from ``f`` on, within the
        window (the track of a tentative start is output a few frames after its event)."""
        if t is None:
            return None, None
        fs = self.visible.get(t, [])
        k = bisect.bisect_left(fs, f)
        while k < len(fs) and fs[k] - f <= self.window:
            g = self.match.get((t, fs[k]))
            if g is not None:
                return g, fs[k]
            k += 1
        return None, None

    def border_box(self, box: np.ndarray) -> bool:
        w, h = self.gt.image_size
        m = self.c.border_margin_px
        return bool(box[0] <= m or box[1] <= m or box[2] >= w - m or box[3] >= h - m)

    def entered_at_border(self, g: int, f: int) -> bool:
        """Object ``g`` is at the border at ``f``, or its labelled track began at the border
        within the window of ``f``."""
        i = self.t.row.get((g, f))
        if i is not None and self.t.at_border[i]:
            return True
        f0 = self.t.frames[g][0]
        return (
            bool(self.t.at_border[self.t.row[(g, f0)]])
            and abs(f0 - f) <= self.window
            and f0 > self.gt.first_frame
        )

    def left_at_border(self, g: int, f: int) -> bool:
        """Object ``g`` is at the border at ``f``, or its labelled track ended at the border
        within the window of ``f``."""
        i = self.t.row.get((g, f))
        if i is not None and self.t.at_border[i]:
            return True
        f1 = self.t.frames[g][-1]
        last = self.gt.first_frame + self.gt.n_frames - 1
        return (
            bool(self.t.at_border[self.t.row[(g, f1)]])
            and abs(f1 - f) <= self.window
            and f1 < last
        )


class _OcclusionJudge(_Evidence):
    """``hides_behind``, ``unhides_from_behind`` / ``reappears`` and ``missing_detections``."""

    def hides(self, ev: Event, unhide: Event | None) -> Verdict:
        t, o = _track(ev, 0), _track(ev, 1)
        f = ev.frame
        g_t, f_t = self.gt_before(t, f)
        g_o, _ = self.gt_before(o, f, inclusive=True)
        border = t is not None and f_t is not None and self.border_box(self.box[(t, f_t)])
        ident = self._identity(g_t, unhide)
        gts = (g_t, g_o)
        if g_t is None or g_o is None:
            return Verdict(ev, UNDECIDABLE, "unmatched", gts, border, ident)
        if g_t == g_o:
            return Verdict(ev, IMPLAUSIBLE, "self", gts, border, ident)
        tr = self.t
        i_t = tr.row.get((g_t, f))
        if i_t is None:  # not labelled at f: left the view, or hidden inside it
            f_last = tr.last_before(g_t, f)
            if f_last is None:
                return Verdict(ev, UNDECIDABLE, "not_labelled", gts, border, ident)
            j = tr.row[(g_t, f_last)]
            if tr.at_border[j]:
                return Verdict(ev, IMPLAUSIBLE, "left_view", gts, border, ident)
            occluded: bool | None = True
        else:
            j = i_t
            occluded = tr.occluded(i_t)
        f_o = f if (g_o, f) in tr.row else tr.last_before(g_o, f)
        if f_o is None:
            return Verdict(ev, UNDECIDABLE, "occluder_not_labelled", gts, border, ident)
        k = tr.row[(g_o, f_o)]
        bt, bo = tr.xyxy[j], tr.xyxy[k]
        if tr.loc is not None:
            in_front = bool(tr.loc[k, 2] < tr.loc[j, 2])
        else:
            in_front = bool(bo[3] > bt[3])
        iw = min(bt[2], bo[2]) - max(bt[0], bo[0])
        ih = min(bt[3], bo[3]) - max(bt[1], bo[1])
        area = (bt[2] - bt[0]) * (bt[3] - bt[1])
        cover = max(iw, 0.0) * max(ih, 0.0) / area if area > 0 else 0.0
        if occluded is False:
            return Verdict(ev, IMPLAUSIBLE, "not_occluded", gts, border, ident)
        if not in_front:
            return Verdict(ev, IMPLAUSIBLE, "occluder_behind", gts, border, ident)
        if cover < self.c.min_cover:
            return Verdict(ev, IMPLAUSIBLE, "occluder_not_covering", gts, border, ident)
        if occluded is None:
            return Verdict(ev, UNDECIDABLE, "occlusion_unknown", gts, border, ident)
        return Verdict(ev, PLAUSIBLE, "occluded_in_front", gts, border, ident)

    def _identity(self, g_t: int | None, unhide: Event | None) -> str:
        if unhide is None:
            return "not_resumed"
        t2 = _track(unhide)
        g2 = None if t2 is None else self.match.get((t2, unhide.frame))
        if g_t is None or g2 is None:
            return "unknown"
        return "kept" if g2 == g_t else "switched"

    def same_identity(self, ev: Event) -> Verdict:
        """unhides_from_behind / reappears (and a revived track's reenters_fov / returns): the
        same object before and after the gap."""
        t, f = _track(ev), ev.frame
        g1, _ = self.gt_before(t, f)
        g2 = None if t is None else self.match.get((t, f))
        if g1 is None or g2 is None:
            return Verdict(ev, UNDECIDABLE, "unmatched", (g1, g2))
        if g1 != g2:
            return Verdict(ev, IMPLAUSIBLE, "identity_switch", (g1, g2))
        return Verdict(ev, PLAUSIBLE, "same_object", (g1, g2))

    def missing(self, ev: Event) -> Verdict:
        g, _ = self.gt_before(_track(ev), ev.frame)
        if g is None:
            return Verdict(ev, UNDECIDABLE, "unmatched", (g,))
        if (g, ev.frame) in self.t.row:
            return Verdict(ev, PLAUSIBLE, "in_view", (g,))
        f_last = self.t.last_before(g, ev.frame)
        if f_last is not None and self.t.at_border[self.t.row[(g, f_last)]]:
            return Verdict(ev, IMPLAUSIBLE, "left_view", (g,))
        return Verdict(ev, PLAUSIBLE, "unlabelled_inside", (g,))


class _BorderJudge(_Evidence):
    """``enters_fov``, ``starts``, ``leaves_fov`` and ``ends``."""

    def enters(self, ev: Event) -> Verdict:
        g, _ = self.gt_from(_track(ev), ev.frame)
        if g is None:
            return Verdict(ev, UNDECIDABLE, "unmatched", (g,))
        if self.entered_at_border(g, ev.frame):
            return Verdict(ev, PLAUSIBLE, "crossed_border", (g,))
        return Verdict(ev, IMPLAUSIBLE, "inside_image", (g,))

    def starts(self, ev: Event) -> Verdict:
        g, _ = self.gt_from(_track(ev), ev.frame)
        if g is None:
            return Verdict(ev, UNDECIDABLE, "unmatched", (g,))
        if ev.frame == self.gt.first_frame:
            return Verdict(ev, PLAUSIBLE, "first_frame", (g,))
        if self.entered_at_border(g, ev.frame):
            return Verdict(ev, IMPLAUSIBLE, "entered_at_border", (g,))
        return Verdict(ev, PLAUSIBLE, "appeared_inside", (g,))

    def leaves(self, ev: Event) -> Verdict:
        g, f_v = self.gt_before(_track(ev), ev.frame, inclusive=True)
        if g is None:
            return Verdict(ev, UNDECIDABLE, "unmatched", (g,))
        if self.left_at_border(g, ev.frame) or (f_v is not None and self.left_at_border(g, f_v)):
            return Verdict(ev, PLAUSIBLE, "crossed_border", (g,))
        return Verdict(ev, IMPLAUSIBLE, "inside_image", (g,))

    def ends(self, ev: Event) -> Verdict:
        g, f_v = self.gt_before(_track(ev), ev.frame, inclusive=True)
        if g is None:
            return Verdict(ev, UNDECIDABLE, "unmatched", (g,))
        if self.left_at_border(g, ev.frame) or (f_v is not None and self.left_at_border(g, f_v)):
            return Verdict(ev, IMPLAUSIBLE, "left_view", (g,))
        return Verdict(ev, PLAUSIBLE, "lost_inside", (g,))


def _stated_confidence(w: Mapping[str, Any]) -> float | None:
    """A warning record's confidence (0..1: the record's, else its details'), None if it
    states none or not a number in that range."""
    level = w.get("confidence", (w.get("details") or {}).get("confidence"))
    if isinstance(level, bool) or not isinstance(level, (int, float)):
        return None
    return float(level) if 0.0 <= level <= 1.0 else None


class _WarningJudge(_Evidence):
    """HIDDEN_ENTITY, OVERTAKING and SUDDEN_STOP warnings."""

    @staticmethod
    def _opened(
        w: Mapping[str, Any], kind: str, **known: Any
    ) -> tuple[int, tuple[int, ...], Callable[..., WarningVerdict]]:
        """A warning record's frame and objects, and its verdict with them, its stated
        confidence and ``known`` filled in."""
        f, objs = int(w["frame"]), tuple(int(o) for o in w["objects"])
        judged = partial(WarningVerdict, f, kind, objs, confidence=_stated_confidence(w), **known)
        return f, objs, judged

    def hidden_entity(self, w: Mapping[str, Any]) -> WarningVerdict:
        f, objs, judged = self._opened(w, "HIDDEN_ENTITY")
        details = w.get("details") or {}
        g, _ = self.gt_before(objs[0], f)
        ant = details.get("anticipation") or {}
        pred_frame = details.get("reappear_frame", ant.get("reappear_frame"))
        pos = ant.get("position")
        if g is None:
            return judged(verdict=UNDECIDABLE, reason="unmatched")
        prediction = _prediction(pred_frame, pos)
        if prediction is None:  # no anticipation in the record
            return judged(verdict=UNDECIDABLE, reason="no_prediction", gt=g)
        pred_frame, px_pred, py_pred = prediction
        tr = self.t
        back = next(
            (h for h in tr.frames.get(g, []) if h > f and tr.visible(tr.row[(g, h)])), None
        )
        if back is None:
            return judged(verdict=IMPLAUSIBLE, reason="never_reappeared", gt=g, reappeared=False)
        i = tr.row[(g, back)]
        x1, _, x2, y2 = tr.xyxy[i]
        px = float(math.hypot((x1 + x2) / 2 - px_pred, y2 - py_pred))
        ferr = int(back - pred_frame)
        in_lane = None if tr.loc is None else bool(abs(tr.loc[i, 0]) <= self.c.lane_half_width_m)
        ok = abs(ferr) <= self.c.reappear_frames and px <= self.c.reappear_px
        reason = (
            "on_target"
            if ok
            else ("late_or_early" if abs(ferr) > self.c.reappear_frames else "elsewhere")
        )
        return judged(
            verdict=PLAUSIBLE if ok else IMPLAUSIBLE,
            reason=reason,
            gt=g,
            reappeared=True,
            frame_error=ferr,
            px_error=round(px, 1),
            lead_frames=int(back - f),
            in_lane=in_lane,
        )

    def overtaking(self, w: Mapping[str, Any]) -> WarningVerdict:
        """A overtakes B: in 3D, A was nearer than B at ``details.nearer_until`` (else one window
        before) and is farther now, the two side by side (``|X_A - X_B|`` >= ``min_side_m``)."""
        f, objs, judged = self._opened(w, "OVERTAKING")
        if len(objs) != 2:
            return judged(verdict=UNDECIDABLE, reason="unmatched")
        g_a, _ = self.gt_before(objs[0], f, inclusive=True)
        g_b, _ = self.gt_before(objs[1], f, inclusive=True)
        tr = self.t
        if g_a is None or g_b is None:
            return judged(verdict=UNDECIDABLE, reason="unmatched", gt=g_a)
        if g_a == g_b:
            return judged(verdict=IMPLAUSIBLE, reason="self", gt=g_a)
        if tr.loc is None:
            return judged(verdict=UNDECIDABLE, reason="no_3d", gt=g_a)
        until = (w.get("details") or {}).get("nearer_until")
        f0 = int(until) if isinstance(until, (int, float)) else f - self.window
        history = [(tr.last_before(g, h), g) for h in (f0, f) for g in (g_a, g_b)]
        frames = [(h, g) for h, g in history if h is not None]
        if len(frames) < len(history):
            return judged(verdict=UNDECIDABLE, reason="no_history", gt=g_a)
        za0, zb0, za1, zb1 = (tr.loc[tr.row[(g, h)], 2] for h, g in frames)
        side = abs(tr.loc[tr.row[(g_a, frames[2][0])], 0] - tr.loc[tr.row[(g_b, frames[3][0])], 0])
        judged_pair = partial(judged, gt=g_a, lateral_m=round(float(side), 2))
        if not (za0 < zb0 and za1 > zb1):
            return judged_pair(verdict=IMPLAUSIBLE, reason="no_depth_flip")
        if side < self.c.min_side_m:
            return judged_pair(verdict=IMPLAUSIBLE, reason="same_lane")
        return judged_pair(verdict=PLAUSIBLE, reason="passed_in_depth")

    def sudden_stop(self, w: Mapping[str, Any]) -> WarningVerdict:
        warned = (w.get("details") or {}).get("ttc_s")
        f, objs, judged = self._opened(
            w, "SUDDEN_STOP", warned_ttc_s=None if warned is None else float(warned)
        )
        g, _ = self.gt_before(objs[0], f, inclusive=True)
        tr = self.t
        if g is None:
            return judged(verdict=UNDECIDABLE, reason="unmatched")
        if tr.loc is None:
            return judged(verdict=UNDECIDABLE, reason="no_3d", gt=g)
        now = tr.last_before(g, f)
        span = max(1, int(round(self.c.ttc_span_s * self.gt.fps)))
        before = tr.first_after(g, f - span) if now is not None else None
        if now is None or before is None or before >= now:
            return judged(verdict=UNDECIDABLE, reason="no_history", gt=g)
        i, j = tr.row[(g, now)], tr.row[(g, before)]
        closing = (tr.loc[j, 2] - tr.loc[i, 2]) * self.gt.fps / (now - before)
        gap = tr.loc[i, 2] - (0.0 if tr.half_depth is None else tr.half_depth[i])
        ttc = float(max(gap, 0.0) / closing) if closing > 0 else math.inf
        lateral = float(abs(tr.loc[i, 0]))
        ttc_r = round(ttc, 2) if math.isfinite(ttc) else ttc
        judged_ttc = partial(judged, gt=g, ttc_s=ttc_r, lateral_m=round(lateral, 2))
        if lateral > self.c.lane_half_width_m:
            return judged_ttc(verdict=IMPLAUSIBLE, reason="to_the_side")
        if ttc > self.c.ttc_max_s:
            return judged_ttc(
                verdict=IMPLAUSIBLE,
                reason="not_closing" if closing <= 0 else "ttc_long",
            )
        return judged_ttc(verdict=PLAUSIBLE, reason="closing_in_lane")


class _Recall(_Evidence):
    """The occasions an event was due, and whether it was said."""

    #: hides_behind recall occasions by what the tracker said at them (see :meth:`recall`)
    hide_said: Counter[str]
    #: the confidence of the hides_behind event of each explained occasion
    hide_hit_confidence: list[float]

    def recall(self, events: list[Event]) -> dict[str, tuple[int, int]]:
        """Occasions in the ground truth where an event of a kind was due, and how many got one.

        hides_behind: a matched track's object is occluded (per the ground truth, labelled, not
        at the border) at the first frame the track is not output; what the tracker said there
        instead (``leaves_fov``, ``missing_detections``, ``ends`` or ``nothing``) is counted in
        ``self.hide_said``. enters_fov / leaves_fov: a
        labelled track that begins / ends at the border (not at the sequence's first / last
        frame) and is matched by a track within the window of that frame."""
        names: dict[str, set[tuple[int | str, int]]] = defaultdict(set)
        by_track: dict[int | str, set[str]] = defaultdict(set)
        hide_level: dict[tuple[int | str, int], float] = {}
        for e in events:
            if e.args:  # a user's encoding may abduce events without arguments
                names[e.name].add((e.args[0], e.frame))
                by_track[e.args[0]].add(e.name)
                if e.name == "hides_behind":
                    level = 1.0 if e.confidence is None else float(e.confidence)
                    key = (e.args[0], e.frame)
                    hide_level[key] = max(level, hide_level.get(key, 0.0))
        tr = self.t
        hide_hit = hide_all = 0
        self.hide_said = Counter()
        self.hide_hit_confidence = []
        for t, fs in self.visible.items():
            for a, b in zip(fs, fs[1:] + [None], strict=True):
                f = a + 1
                if b == f or f >= self.gt.first_frame + self.gt.n_frames:
                    continue
                g = self.match.get((t, a))
                i = None if g is None else tr.row.get((g, f))
                if i is None or tr.at_border[i] or not tr.occluded(i):
                    continue
                hide_all += 1
                said = next((n for n in _SAID_INSTEAD if (t, f) in names[n]), "nothing")
                self.hide_said[said] += 1
                if said == "hides_behind":
                    hide_hit += 1
                    self.hide_hit_confidence.append(hide_level[(t, f)])
        last = self.gt.first_frame + self.gt.n_frames - 1
        tracks_of: dict[int, list[tuple[int, int]]] = defaultdict(list)
        for (t, f), g in self.match.items():
            tracks_of[g].append((f, t))
        enter_hit = enter_all = leave_hit = leave_all = 0
        for g, fs in tr.frames.items():
            seen = sorted(tracks_of.get(g, []))
            if not seen:
                continue
            f0, f1 = fs[0], fs[-1]
            if f0 > self.gt.first_frame and tr.at_border[tr.row[(g, f0)]]:
                near = [t for f, t in seen if abs(f - f0) <= self.window]
                if near:
                    enter_all += 1
                    enter_hit += "enters_fov" in by_track[near[0]]
            if f1 < last and tr.at_border[tr.row[(g, f1)]]:
                near = [t for f, t in seen if abs(f - f1) <= self.window]
                if near:
                    leave_all += 1
                    leave_hit += "leaves_fov" in by_track[near[-1]]
        out = {"enters_fov": (enter_hit, enter_all), "leaves_fov": (leave_hit, leave_all)}
        if tr.occl is not None or tr.vis is not None:
            out["hides_behind"] = (hide_hit, hide_all)
        return out


class _Judge(_OcclusionJudge, _BorderJudge, _WarningJudge, _Recall):
    """Every judgement of one sequence, on one :class:`_Evidence`."""


#: what a track's first unseen frame may be explained as, in the order the recall reads them
_SAID_INSTEAD = ("hides_behind", "leaves_fov", "missing_detections", "ends")
_SAID_KINDS = (*_SAID_INSTEAD, "nothing")


def _prediction(frame: Any, position: Any) -> tuple[int, float, float] | None:
    """``(frame, x, y)`` pixels of a warning record's predicted reappearance (None: none there,
    or not numbers)."""
    if frame is None or position is None:
        return None
    try:
        return int(frame), float(position[0]), float(position[1])
    except (TypeError, ValueError, IndexError):
        return None


def _track(ev: Event, k: int = 0) -> int | None:
    """Argument ``k`` of an event as a track id (None: a constant, which names no track)."""
    arg = ev.args[k]
    return None if isinstance(arg, str) else arg


def _event_order(e: Event) -> tuple[int, str, tuple[tuple[bool, int | str], ...]]:
    """Events' own order (frame, name, args), with constants after track ids: never compares
    a constant with a number."""
    return e.frame, e.name, tuple((isinstance(a, str), a) for a in e.args)


def late_start_events(tracks: Detections, events: Iterable[Event]) -> tuple[int, int]:
    """``(late, total)``: ``starts`` and ``enters_fov`` events dated before the first frame their
    track is output (tentative tracks: the event log and the tracks disagree), and all of them."""
    first: dict[int, int] = {}
    assert tracks.tracker_id is not None and tracks.frame is not None  # filled on construction
    for t, f in zip(tracks.tracker_id.tolist(), tracks.frame.tolist(), strict=True):
        if t not in first or f < first[t]:
            first[t] = f
    late = total = 0
    for e in events:
        if e.name in START_EVENTS:
            total += 1
            t = _track(e)
            late += t is None or e.frame < first.get(t, e.frame + 1)
    return late, total


def load_ground_truth(
    path: str | Any,
    fmt: str,
    *,
    image_size: tuple[int, int],
    fps: float,
    classes: Sequence[str] = ("car",),
    n_frames: int | None = None,
) -> GroundTruth:
    """Read a ground-truth file: ``fmt`` ``"kitti"`` (``label_02/<seq>.txt``; ``classes`` the
    tracked ones) or ``"mot"`` (``gt/gt.txt``). Raises :class:`~sensemaking.errors.InputError`."""
    if fmt == "kitti":
        from sensemaking.io.kitti import read_kitti_labels

        return GroundTruth.from_kitti(
            read_kitti_labels(path),
            image_size=image_size,
            fps=fps,
            classes=classes,
            n_frames=n_frames,
        )
    from sensemaking.io.mot import read_mot

    return GroundTruth.from_mot(
        read_mot(path, kind="gt"), image_size=image_size, fps=fps, n_frames=n_frames
    )


def evaluate_explanations(
    gt: GroundTruth,
    tracks: Detections,
    events: Iterable[Event],
    warnings: Iterable[Mapping[str, Any]] = (),
    *,
    name: str = "",
    config: ExplanationConfig | None = None,
) -> ExplanationResult:
    """Judge every event and HIDDEN_ENTITY, SUDDEN_STOP and OVERTAKING warning of one sequence.

    Args:
        gt: the sequence's ground truth (:class:`GroundTruth`).
        tracks: the boxes the tracker output as visible (``tracker_id``, ``frame``, ``xyxy``).
        events: the event log (``Event`` or its JSON records are read by the CLI).
        warnings: warning records (:mod:`sensemaking.records`); other situations, notes and
            end records are skipped.
        name: the sequence name. config: thresholds (default :class:`ExplanationConfig`).
    """
    config = config or ExplanationConfig()
    events = sorted(events, key=_event_order)
    judge = _Judge(gt, tracks, config)
    unhides: dict[int | str, list[Event]] = defaultdict(list)
    for e in events:
        if e.name == "unhides_from_behind":
            unhides[e.args[0]].append(e)
    out = ExplanationResult(name)
    for e in events:
        if e.name in _HIDING_KINDS:
            nxt = next((u for u in unhides[e.args[0]] if u.frame > e.frame), None)
            out.events.append(judge.hides(e, nxt))
        elif e.name in ("unhides_from_behind", "reappears", "reenters_fov", "returns"):
            out.events.append(judge.same_identity(e))
        elif e.name == "enters_fov":
            out.events.append(judge.enters(e))
        elif e.name == "starts":
            out.events.append(judge.starts(e))
        elif e.name == "leaves_fov":
            out.events.append(judge.leaves(e))
        elif e.name == "ends":
            out.events.append(judge.ends(e))
        elif e.name == "missing_detections":
            out.events.append(judge.missing(e))
    for w in judged_warnings(warnings):
        if w.get("situation") == "HIDDEN_ENTITY":
            out.warnings.append(judge.hidden_entity(w))
        elif w.get("situation") == "SUDDEN_STOP":
            out.warnings.append(judge.sudden_stop(w))
        elif w.get("situation") == "OVERTAKING":
            out.warnings.append(judge.overtaking(w))
    out.late_starts, out.starts_total = late_start_events(tracks, events)
    log.debug(
        "%s: %d events and %d warnings judged",
        name or "sequence",
        len(out.events),
        len(out.warnings),
    )
    out.recall = judge.recall(events)
    if "hides_behind" in out.recall:
        out.occlusions_said = dict(judge.hide_said)
        out.hide_hit_confidence = list(judge.hide_hit_confidence)
    return out


# -- the table ------------------------------------------------------------------------------------
def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.1f}"


def explanation_table(
    results: Mapping[str, Sequence[ExplanationResult] | ExplanationResult | Mapping[str, Any]],
) -> str:
    """The explanation-quality table (markdown), one block of rows per benchmark.

    ``results``: benchmark name -> its sequences' results, one combined result, or the
    :meth:`ExplanationResult.summary` of one (what the benchmark report keeps). Columns per
    event kind: counts plausible / implausible / undecidable, precision (plausible of the
    decidable, %), plausible of all (%), recall (%) where defined, and the notes of
    docs/EXPLANATIONS.md (border, self, identity kept; HIDDEN_ENTITY on target)."""
    lines = [
        "| benchmark | kind | n | plausible | implausible | undecidable | precision % "
        "| plausible of all % | recall % | notes |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for bench, res in results.items():
        s = _summary_of(res)
        for kind in EVENT_KINDS:
            row = s["events"][kind]
            if not row["total"]:
                continue
            notes = []
            if kind in _HIDING_KINDS:
                ident = row["identity"]
                notes.append(
                    f"self {row['self']}; implausible at border {row['implausible_at_border']}; "
                    f"identity kept {ident['kept']} / switched {ident['switched']}"
                )
            top = _implausible_reasons(row)[:3]
            if top:
                notes.append("implausible: " + ", ".join(top))
            recall = "-"
            if "recall_occasions" in row:
                recall = f"{_pct(row['recall'])} of {row['recall_occasions']}"
            said = row.get("occlusions_said")
            if said and row["recall_occasions"]:
                other = [f"{k} {n}" for k, n in said.items() if n and k != "hides_behind"]
                notes.append("occluded when lost, said instead: " + (", ".join(other) or "-"))
            lines.append(_row(bench, kind, row, recall, "; ".join(notes)))
        for kind in WARNING_KINDS:
            row = s["warnings"][kind]
            if not row["total"]:
                continue
            if kind == "HIDDEN_ENTITY":
                note = (
                    f"reappeared {row['reappeared']}, never {row['never_reappeared']}; "
                    f"on target {_pct(row['on_target_of_reappeared'])} % of reappeared; "
                    f"median error {_fmt(row['median_frame_error'])} frames, "
                    f"{_fmt(row['median_px_error'])} px; "
                    f"median lead {_fmt(row['median_lead_frames'])} frames"
                )
                if row["in_lane"] is not None:
                    note += f"; in ego lane {row['in_lane']}"
            else:
                note = "implausible: " + ", ".join(_implausible_reasons(row))
            lines.append(_row(bench, kind, row, "-", note))
        lines.append(
            f"| {bench} | starts/enters_fov before the track's first output frame | "
            f"{s['starts_total']} | | | | | | | {s['late_starts']} of {s['starts_total']} |"
        )
    return "\n".join(lines) + "\n"


def confidence_text(
    results: Mapping[str, Sequence[ExplanationResult] | ExplanationResult | Mapping[str, Any]],
) -> str:
    """The ``hides_behind`` precision-recall table (markdown) against the events' confidence:
    one row per benchmark and threshold (events at or above it kept); then, for the warnings
    that state a confidence, their precision and the share of the right
    (plausible) warnings kept at each threshold; empty without either."""
    lines = [
        "| benchmark | hides_behind confidence >= | n | plausible | implausible | precision % "
        "| recall % |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    warned = [
        "| benchmark | warning | confidence >= | n | plausible | implausible | precision % "
        "| right warnings kept % |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for bench, res in results.items():
        summary = _summary_of(res)
        row = summary["events"]["hides_behind"]
        for r in row.get("by_confidence", []) if row["total"] else []:
            lines.append(
                f"| {bench} | {r['threshold']:.1f} | {r['n']} | {r[PLAUSIBLE]} "
                f"| {r[IMPLAUSIBLE]} | {_pct(r['precision'])} | {_pct(r['recall'])} |"
            )
        for kind, wrow in summary["warnings"].items():
            for r in wrow.get("by_confidence", []) if wrow["total"] else []:
                warned.append(
                    f"| {bench} | {kind} | {r['threshold']:.1f} | {r['n']} | {r[PLAUSIBLE]} "
                    f"| {r[IMPLAUSIBLE]} | {_pct(r['precision'])} | {_pct(r['recall'])} |"
                )
    out = "\n".join(lines) + "\n" if len(lines) > 2 else ""
    if len(warned) > 2:
        out += ("\n" if out else "") + "\n".join(warned) + "\n"
    return out


def spread_table(
    results: Mapping[str, Sequence[ExplanationResult]],
    kinds: Sequence[str] = (*EVENT_KINDS, *WARNING_KINDS),
) -> str:
    """Per-sequence spread of the precision (markdown): per benchmark and kind judged on at
    least one sequence with a decidable verdict, the number of such sequences, the lowest,
    median and highest precision among them, the pooled precision, and every sequence's
    ``plausible/decidable``. A pooled share can hide one sequence that carries it."""
    lines = [
        "| benchmark | kind | sequences | lowest % | median % | highest % | pooled % "
        "| per sequence (plausible/decidable) |",
        "|---|---|---:|---:|---:|---:|---:|---|",
    ]
    for bench, seqs in results.items():
        for kind in kinds:
            rows = []
            for r in seqs:
                verdicts = [v.verdict for v in r.events if v.event.name == kind] + [
                    w.verdict for w in r.warnings if w.situation == kind
                ]
                p, i = verdicts.count(PLAUSIBLE), verdicts.count(IMPLAUSIBLE)
                if p + i:
                    rows.append((r.name, p, p + i))
            if not rows:
                continue
            shares = [p / d for _, p, d in rows]
            pooled = sum(p for _, p, _ in rows) / sum(d for _, _, d in rows)
            each = ", ".join(f"{name} {p}/{d}" for name, p, d in rows)
            lines.append(
                f"| {bench} | {kind} | {len(rows)} | {_pct(min(shares))} "
                f"| {_pct(float(np.median(shares)))} | {_pct(max(shares))} | {_pct(pooled)} "
                f"| {each} |"
            )
    return "\n".join(lines) + "\n" if len(lines) > 2 else ""


def _summary_of(
    res: Sequence[ExplanationResult] | ExplanationResult | Mapping[str, Any],
) -> Mapping[str, Any]:
    if isinstance(res, ExplanationResult):
        return res.summary()
    if isinstance(res, Mapping):
        return res
    return ExplanationResult.combine(res).summary()


def _row(bench: str, kind: str, row: Mapping[str, Any], recall: str, notes: str) -> str:
    cells = [
        bench,
        kind,
        row["total"],
        row[PLAUSIBLE],
        row[IMPLAUSIBLE],
        row[UNDECIDABLE],
        _pct(row["precision"]),
        _pct(row["plausible_of_all"]),
        recall,
        notes,
    ]
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _implausible_reasons(row: Mapping[str, Any]) -> list[str]:
    """``"reason count"`` of the implausible verdicts of a summary row, most frequent first."""
    found = [
        (n, k.split(":", 1)[1]) for k, n in row["reasons"].items() if k.startswith(IMPLAUSIBLE)
    ]
    return [f"{reason} {n}" for n, reason in sorted(found, key=lambda x: (-x[0], x[1]))]


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:g}"

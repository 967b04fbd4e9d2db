"""Estimate tracker parameters from annotated sequences: a detector's scores, a camera's borders.

Input: pairs of ground truth and detections of the same sequences (the user's detector on the
user's camera). Each detection is matched to the ground truth of its frame (Hungarian, IoU >= 0.5);
matched detections are *true*, the others *false*. From those:

- **Score thresholds** from ``P(true | score)``, estimated in score bins (equal counts) and made
  non-decreasing from the top: ``start_confidence`` is the lowest score from which a detection is
  more often true than false (``P >= 0.5``: a track is started on the likelier explanation);
  ``confirm_confidence`` the lowest from which ``P >= 0.99`` (null if never); ``min_confidence``
  keeps 98 % of the true detections' scores (capped at ``start_confidence``): a detection that
  fits a live track continues it even when it could not start one.
- **min_hits** from the false detections that repeat: false detections above the start threshold
  linked frame to frame (IoU >= 0.5) form false chains; ``min_hits`` is the least number of
  frames that at most 10 % of them last (1 to 5).
- **max_missing_s** from the gaps of annotated objects: the 95th percentile of the runs of frames
  an annotated object goes without a matched detection and then comes back, in seconds.
- **Border costs** as negative log-likelihoods, 100 solver units per nat (``-100 ln p``; a perfect
  IoU match is worth 1000): ``enters`` / ``appears`` from how often annotated objects begin at the
  image border (within ``border_margin``) or away from it, ``leaves`` / ``lost`` from where they
  end (objects still there in the last frame do not count), add-one smoothed. Needs the image
  size.

Everything else stays at the family preset named as the file's ``base``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence as SequenceABC
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.geometry import box_area, intersection, iou

__all__ = [
    "CalibrationSequence",
    "Calibration",
    "ESTIMATED",
    "annotated_sequence",
    "calibrate",
    "UNITS_PER_NAT",
]

log = logging.getLogger(__name__)

#: solver units per nat of a negative log-likelihood
UNITS_PER_NAT = 100.0
_MATCH_IOU = 0.5
_BINS = 20
_COST_RANGE = (0, 2000)
#: every parameter :func:`calibrate` can estimate (a key is left out of its result when the data
#: hold no evidence for it: no gap, no object beginning or ending inside the sequence)
ESTIMATED: tuple[str, ...] = (
    "start_confidence",
    "min_confidence",
    "confirm_confidence",
    "min_hits",
    "max_missing_s",
    "costs.enters",
    "costs.appears",
    "costs.leaves",
    "costs.lost",
)


@dataclass(frozen=True, eq=False)
class CalibrationSequence:
    """One annotated sequence: ground truth of the class of interest (``tracker_id`` = object id),
    the detector's boxes (``confidence`` = score), its length in frames and first frame number,
    frame rate (frames / s), image size (pixels, or None), a name for messages, and ``ignore``:
    annotated boxes that are neither the class nor background (other classes, DontCare regions,
    MOT's not-considered boxes); a detection on one of them counts as neither true nor false.
    ``path``: the detections file, named by the errors of the sequence (else its name)."""

    name: str
    gt: Detections
    detections: Detections
    first_frame: int
    n_frames: int
    fps: float
    image_size: tuple[int, int] | None = None
    ignore: Detections | None = None
    path: str | None = None

    def error(self, problem: str) -> InputError:
        """An InputError of this sequence, naming its detections file (else its name)."""
        if self.path is None:
            return InputError(f"{self.name}: {problem}")
        return InputError(problem, self.path)


def annotated_sequence(
    name: str,
    gt: Detections,
    detections: Detections,
    class_id: int,
    first_frame: int,
    n_frames: int,
    fps: float,
    image_size: tuple[int, int] | None = None,
    path: str | None = None,
) -> CalibrationSequence:
    """A :class:`CalibrationSequence` from a whole ground-truth file as read (every class; MOT's
    ``consider`` flag in ``gt.data``): rows of ``class_id`` with an object id (and considered)
    are the ground truth, every other annotated box is ``ignore``; ``path``: the detections
    file (for messages)."""
    assert gt.class_id is not None and gt.tracker_id is not None  # set by __post_init__
    target = (gt.class_id == class_id) & (gt.tracker_id >= 0)
    if "consider" in gt.data and len(gt):
        target &= np.asarray(gt.data["consider"]) != 0
    return CalibrationSequence(
        name=name,
        gt=gt[target],
        detections=detections,
        first_frame=first_frame,
        n_frames=n_frames,
        fps=float(fps),
        image_size=image_size,
        ignore=gt[~target],
        path=path,
    )


@dataclass
class Calibration:
    """Estimated parameters (dotted keys, the units of ``docs/PARAMETERS.md``) and the counts
    they came from."""

    params: dict[str, Any]
    stats: dict[str, Any] = field(default_factory=dict)

    def source(self) -> str:
        s = self.stats
        return (
            f"sensemaking calibrate on {s['sequences']} sequence(s) ({', '.join(s['names'])}): "
            f"{s['true']} true and {s['false']} false detections (IoU >= {_MATCH_IOU} with the "
            f"ground truth), {s['objects']} annotated objects, {s['gaps']} gaps; thresholds from "
            "P(true | score), min_hits from repeating false detections, max_missing_s from gaps, "
            f"border costs as -{UNITS_PER_NAT:g} ln p."
        )


def _match(gt: Detections, dets: Detections) -> tuple[np.ndarray, np.ndarray]:
    """(per detection: matched ground-truth row or -1, per gt row: matched detection or -1) for
    one frame."""
    d_match = np.full(len(dets), -1, dtype=np.int64)
    g_match = np.full(len(gt), -1, dtype=np.int64)
    if len(gt) and len(dets):
        overlap = iou(dets.xyxy, gt.xyxy)
        rows, cols = linear_sum_assignment(-overlap)
        ok = overlap[rows, cols] >= _MATCH_IOU
        d_match[rows[ok]] = cols[ok]
        g_match[cols[ok]] = rows[ok]
    return d_match, g_match


def _precision_curve(scores: np.ndarray, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(bin lower edges, P(true) per bin made non-decreasing in score), bins of equal counts."""
    order = np.argsort(scores, kind="stable")
    s, t = scores[order], true[order].astype(float)
    parts = np.array_split(np.arange(len(s)), min(_BINS, len(s)))
    edges = np.array([s[p[0]] for p in parts if len(p)])
    prec = np.array([t[p].mean() for p in parts if len(p)])
    # P(true | score) should not fall as the score rises: the running minimum from the top
    return edges, np.minimum.accumulate(prec[::-1])[::-1]


def _lowest_from(edges: np.ndarray, prec: np.ndarray, level: float) -> float | None:
    """The lowest bin edge from which every bin has P(true) >= level."""
    ok = prec >= level
    if not ok[-1]:
        return None
    first = len(ok) - int(np.argmin(ok[::-1])) if not ok.all() else 0
    return float(edges[first])


def _cost(p: float) -> int:
    p = min(max(p, 1e-6), 1.0)
    return int(np.clip(round(-UNITS_PER_NAT * math.log(p)), *_COST_RANGE))


def _near_border(box: np.ndarray, size: tuple[int, int], margin: float) -> bool:
    w, h = size
    return bool(
        box[0] <= margin or box[1] <= margin or box[2] >= w - margin or box[3] >= h - margin
    )


def calibrate(
    sequences: SequenceABC[CalibrationSequence], border_margin: float = 10.0
) -> Calibration:
    """Estimate a parameter set from annotated sequences (see the module docstring).

    Raises:
        InputError: no sequence, a sequence without ground truth or detections, or detections on
            frames the ground truth does not cover.
    """
    if not sequences:
        raise InputError("no annotated sequence to calibrate on")
    true_scores: list[np.ndarray] = []
    false_scores: list[np.ndarray] = []
    false_chains: list[tuple[int, float]] = []  # (length in frames, first score)
    gaps: list[int] = []
    fps_values: list[float] = []
    starts = {"border": 0, "inside": 0}
    ends = {"border": 0, "inside": 0}
    n_objects = 0
    if all(len(s.gt) == 0 for s in sequences):
        raise InputError("no ground truth of the class to calibrate in any sequence")
    if all(len(s.detections) == 0 for s in sequences):
        raise InputError("no detections in any sequence")
    for seq in sequences:
        last = seq.first_frame + seq.n_frames - 1
        outside = (seq.detections.frame < seq.first_frame) | (seq.detections.frame > last)
        if outside.any():
            f = int(seq.detections.frame[np.argmax(outside)])
            raise seq.error(
                f"detections on frame {f}, outside the sequence's frames "
                f"{seq.first_frame}..{last}: are these the same sequence?"
            )
        # a video without the class (or without detections) still says what is false (or missed)
        last_rows = [int(x.frame.max()) for x in (seq.gt, seq.ignore) if x is not None and len(x)]
        annotated = max(last_rows) if last_rows else last
        if len(seq.detections) and int(seq.detections.frame.max()) > annotated:
            raise seq.error(
                f"detections reach frame {int(seq.detections.frame.max())}, the "
                f"ground truth ends at frame {annotated}: are these the same sequence?"
            )
        fps_values.append(float(seq.fps))
        gt_by = dict(seq.gt.frames())
        det_by = dict(seq.detections.frames())
        ign_by = dict(seq.ignore.frames()) if seq.ignore is not None and len(seq.ignore) else {}
        matched_obj: dict[int, list[int]] = {}  # object id -> frames with a matched detection
        prev_false: Detections | None = None
        prev_chain: np.ndarray = np.zeros(0, dtype=np.int64)
        chain_len: list[int] = []
        chain_score: list[float] = []
        for f in range(seq.first_frame, last + 1):
            g = gt_by.get(f, Detections.empty())
            d = det_by.get(f, Detections.empty())
            d_match, g_match = _match(g, d)
            true = d_match >= 0
            ign = ign_by.get(f)
            if ign is not None and len(d):
                # on a distractor or in a DontCare region: neither true nor false
                inside = (
                    intersection(d.xyxy, ign.xyxy) / np.maximum(box_area(d.xyxy), 1e-9)[:, None]
                )
                skip = ~true & (inside.max(axis=1) >= _MATCH_IOU)
                d, true = d[~skip], true[~skip]
            true_scores.append(d.confidence[true])
            false_scores.append(d.confidence[~true])
            for gi in np.flatnonzero(g_match >= 0):
                matched_obj.setdefault(int(g.tracker_id[gi]), []).append(f)
            # false detections linked to the previous frame's false detections form chains
            fd = d[~true]
            chain = np.full(len(fd), -1, dtype=np.int64)
            if prev_false is not None and len(prev_false) and len(fd):
                overlap = iou(fd.xyxy, prev_false.xyxy)
                rows, cols = linear_sum_assignment(-overlap)
                ok = overlap[rows, cols] >= _MATCH_IOU
                chain[rows[ok]] = prev_chain[cols[ok]]
            for k in range(len(fd)):
                if chain[k] < 0:
                    chain[k] = len(chain_len)
                    chain_len.append(0)
                    chain_score.append(float(fd.confidence[k]))
                chain_len[chain[k]] += 1
            prev_false, prev_chain = fd, chain
        false_chains.extend(zip(chain_len, chain_score, strict=True))
        # objects: where they begin and end, and how long they go unseen in between
        for obj in np.unique(seq.gt.tracker_id):
            rows = np.flatnonzero(seq.gt.tracker_id == obj)
            n_objects += 1
            frames = np.sort(np.asarray(matched_obj.get(int(obj), []), dtype=np.int64))
            if len(frames) > 1:
                gaps.extend(int(x) - 1 for x in np.diff(frames) if x > 1)
            if seq.image_size is None:
                continue
            first_row, last_row = (
                rows[np.argmin(seq.gt.frame[rows])],
                rows[np.argmax(seq.gt.frame[rows])],
            )
            if seq.gt.frame[first_row] > seq.first_frame:
                starts[
                    "border"
                    if _near_border(seq.gt.xyxy[first_row], seq.image_size, border_margin)
                    else "inside"
                ] += 1
            if seq.gt.frame[last_row] < last:
                ends[
                    "border"
                    if _near_border(seq.gt.xyxy[last_row], seq.image_size, border_margin)
                    else "inside"
                ] += 1
    t = np.concatenate(true_scores)
    fl = np.concatenate(false_scores)
    if len(t) == 0:
        raise InputError(
            "no detection matches the ground truth (IoU >= 0.5): are the files of the "
            "same sequence, class and frame numbering?"
        )
    scores = np.concatenate([t, fl])
    is_true = np.concatenate([np.ones(len(t), bool), np.zeros(len(fl), bool)])
    edges, prec = _precision_curve(scores, is_true)
    start = _lowest_from(edges, prec, 0.5)
    start = float(scores.max()) if start is None else start
    confirm = _lowest_from(edges, prec, 0.99)
    keep = float(np.quantile(t, 0.02))
    params: dict[str, Any] = {
        "start_confidence": round(start, 4),
        "min_confidence": round(min(keep, start), 4),
        "confirm_confidence": None if confirm is None else round(confirm, 4),
    }
    strong = [n for n, s in false_chains if s >= start]
    min_hits = 1
    if strong:
        lengths = np.asarray(strong)
        min_hits = next((k for k in range(1, 6) if np.mean(lengths >= k) <= 0.10), 5)
    params["min_hits"] = int(min_hits)
    fps = float(np.median(fps_values))
    if gaps:
        params["max_missing_s"] = round(max(float(np.quantile(gaps, 0.95)), 1.0) / fps, 3)
    # add-one (Laplace) estimates: an event never seen is rare, not impossible
    if sum(starts.values()):
        p = (starts["border"] + 1) / (sum(starts.values()) + 2)
        params["costs.enters"], params["costs.appears"] = _cost(p), _cost(1 - p)
    if sum(ends.values()):
        p = (ends["border"] + 1) / (sum(ends.values()) + 2)
        params["costs.leaves"], params["costs.lost"] = _cost(p), _cost(1 - p)
    stats = {
        "sequences": len(sequences),
        "names": [s.name for s in sequences],
        "true": int(len(t)),
        "false": int(len(fl)),
        "objects": n_objects,
        "gaps": len(gaps),
        "starts": starts,
        "ends": ends,
        "false_chains_above_start": len(strong),
        "precision_curve": {"edges": edges.tolist(), "p_true": prec.tolist()},
    }
    return Calibration(params=params, stats=stats)

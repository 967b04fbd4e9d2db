"""The frame's abduction problem, as a pure function of the track table, the predictions, the
detections and the configuration (lines 2-3 of Algorithm 1: likelihood and gating).

:func:`frame_problem` measures every prediction against every detection (IoU, coverage by
boxes in front, the image border), gates the pairs in numpy on the solver's likelihood grid and
returns the :class:`~sensemaking.abduction.problem.FrameProblem` the encoding reads. Nothing
here changes the tracks; the tracker applies the answer (:mod:`sensemaking.tracker`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from sensemaking.abduction.problem import FrameProblem
from sensemaking.config import TrackerConfig
from sensemaking.detections import Detections
from sensemaking.geometry import (
    box_area,
    cut_by_border,
    front_margin,
    in_front,
    intersection,
    iou,
    iou_from_intersection,
    safe_ratio,
)
from sensemaking.results import TrackState
from sensemaking.track_table import EndedTracks, TrackTable

__all__ = [
    "frame_problem",
    "likelihood",
    "gate",
    "uncertain_boxes",
    "expired",
    "emerges",
    "borders",
    "thresholds",
    "quantize",
    "likelihood_grid",
    "int_columns",
    "revival",
    "headings",
    "size_gaps",
    "best_fit",
    "last_seen_rows",
]

_HIDDEN = int(TrackState.HIDDEN)  # as a plain int: numpy compares it faster than the enum


def quantize(config: TrackerConfig, x: np.ndarray, rounding=np.rint) -> np.ndarray:
    """Values in [0, 1] -> integers 0..1000 on a grid of ``likelihood_levels`` steps."""
    return _quantize(x, config.likelihood_levels, rounding)


def likelihood_grid(config: TrackerConfig) -> list[int]:
    """Every value of the solver's likelihood grid (``likelihood_levels`` + 1 integers)."""
    return quantize(config, np.linspace(0.0, 1.0, config.likelihood_levels + 1)).tolist()


def likelihood(
    tracks: TrackTable, pred: np.ndarray, dets: Detections, config: TrackerConfig
) -> np.ndarray:
    """(T, D) IoU of (widened, for unseen tracks) predictions and detections, 0 where gated."""
    return gate(tracks, pred, dets, config)[0]


def uncertain_boxes(
    tracks: TrackTable, pred: np.ndarray, config: TrackerConfig
) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """(T,) mask of the tracks whose motion is uncertain -- unseen (more with time) or seen
    once (velocity unknown), gated at the lower ``iou_resume`` -- and the extra boxes whose
    fit counts for them, as ``(rows, boxes)`` parts: their widened predictions and, for
    young tracks, the prediction at rest and its widening."""
    c = config
    young = tracks.hits <= 1
    unseen = (tracks.unseen > 0) | young
    parts: list[tuple[np.ndarray, np.ndarray]] = []
    if unseen.any():
        grow = np.minimum(1.0 + c.resume_growth * tracks.unseen, 2.0)
        grow = np.where(young, np.maximum(grow, c.new_track_growth), grow)
        # the widened box admits far matches; an exact fit to the plain prediction still wins
        parts.append((unseen, _widen(pred[unseen], grow[unseen])))
        if c.inherit_motion and young.any():
            # a young track moved with the scene's motion (inherit_motion); in case its own
            # motion differs, a fit at rest counts as well
            v = tracks.kf.velocity()[young, :2]
            rest = pred[young] - np.concatenate([v, v], axis=1)
            parts += [(young, rest), (young, _widen(rest, grow[young]))]
    return unseen, parts


def gate(
    tracks: TrackTable,
    pred: np.ndarray,
    dets: Detections,
    config: TrackerConfig,
    plain: np.ndarray | None = None,
    uncertain: tuple[np.ndarray, list] | None = None,
    extra: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`likelihood` and its values on the solver's grid (:func:`quantize`). A caller that
    has them already passes ``plain`` = ``iou(pred, dets.xyxy)``, ``uncertain`` =
    ``uncertain_boxes(tracks, pred, config)`` and ``extra`` = the iou of its parts' boxes
    (stacked) with the detections."""
    c = config
    if len(pred) == 0 or len(dets) == 0:
        empty = np.zeros((len(pred), len(dets)))
        return empty, empty.astype(np.int64)
    unseen, parts = uncertain_boxes(tracks, pred, config) if uncertain is None else uncertain
    lik = iou(pred, dets.xyxy) if plain is None else plain
    if parts:
        if extra is None:  # one iou call for all parts (iou is elementwise in its rows)
            extra = iou(np.concatenate([b for _, b in parts]), dets.xyxy)
        lik = best_fit(lik, parts, extra)
    else:
        lik = lik.copy()
    same = (
        tracks.cls[:, None] == dets.class_id[None, :]
        if c.class_aware
        else np.ones((len(pred), len(dets)), dtype=bool)
    )
    resume, assign = thresholds(config, c.iou_resume, c.iou_assign)
    # gate on the solver's likelihood grid against its (floored) thresholds, so that the gate
    # admits exactly the pairs the encoding's constraints allow (gating is only an
    # optimisation): comparing the raw IoU instead dropped pairs that round up to the threshold
    q = quantize(config, lik)
    fits = same & (q >= np.where(unseen, resume, assign)[:, None])
    low, _ = c.class_gates(dets.class_id)  # min_confidence, per class where overridden
    ok = fits & (dets.confidence >= low)[None, :]
    if c.weak_confidence is not None:
        # ByteTrack's second association: a weak detection continues a confirmed track seen
        # last frame (velocity known) that it fits closely and that no detection strong
        # enough to continue tracks could continue (strong evidence first, as its cascade)
        weak = (dets.confidence >= c.weak_confidence) & (dets.confidence < low)
        if weak.any():
            settled = ~unseen & tracks.confirmed & ~ok.any(axis=1)
            ok = ok | (fits & weak[None, :] & settled[:, None] & (lik >= c.weak_iou))
    return np.where(ok, lik, 0.0), q


def best_fit(
    plain: np.ndarray, parts: list[tuple[np.ndarray, np.ndarray]], extra: np.ndarray
) -> np.ndarray:
    """(T, D) the better of ``plain`` (a copy) and each part's fit: ``extra`` holds the iou of
    the parts' boxes (stacked in order) with the detections."""
    lik = plain.copy()
    start = 0
    for rows, boxes in parts:  # max is exact and order-free: as one max per part
        lik[rows] = np.maximum(lik[rows], extra[start : start + len(boxes)])
        start += len(boxes)
    return lik


def last_seen_rows(tracks: TrackTable, config: TrackerConfig) -> np.ndarray:
    """(T,) mask of the tracks also looked for at the box where they were last seen
    (``resume_last_seen``): the hidden and missing ones."""
    if not config.resume_last_seen:
        return np.zeros(len(tracks), dtype=bool)
    return tracks.unseen > 0


def thresholds(config: TrackerConfig, *iou: float) -> tuple[int, ...]:
    """IoU thresholds on the solver's grid, rounded down."""
    return _floored_grid(config.likelihood_levels, iou)


def scaled_confidence(conf: np.ndarray, config: TrackerConfig) -> np.ndarray:
    if config.confidence_sigmoid:
        conf = 1.0 / (1.0 + np.exp(-conf))
    return quantize(config, conf)


def borders(
    boxes: np.ndarray, config: TrackerConfig, area: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(at the border, mostly outside) for (N, 4) boxes; all False without an image size.
    ``area``: ``geometry.box_area(boxes)`` if the caller has it already."""
    n = len(boxes)
    if config.image_size is None or n == 0:
        return np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    m, image, far = _image_limits(config.image_size, config.border_margin)
    # x1 <= m or y1 <= m or x2 >= w - m or y2 >= h - m
    near = (boxes[:, :2] <= m) | (boxes[:, 2:] >= far)  # (N, 2): x side, y side
    at = near[:, 0] | near[:, 1]
    area = box_area(boxes) if area is None else area
    inside = safe_ratio(intersection(boxes, image)[:, 0], area)  # geometry.coverage(boxes, image)
    return at, inside < 0.05  # (almost) nothing left in view; detections may stick out far


def frame_problem(
    tracks: TrackTable,
    pred: np.ndarray,
    dets: Detections,
    config: TrackerConfig,
    *,
    first_frame: bool,
    speed: bool,
    gone: EndedTracks | None = None,
) -> FrameProblem:
    """The frame's problem; ``gone``: the tracks that may revive (``revive_s``), their
    predictions for this frame made (see :func:`revival`)."""
    c = config
    n, nd, dxy = len(pred), len(dets), dets.xyxy
    nb = n + nd
    # one intersection of every box (predictions, then detections, then the uncertain
    # tracks' extra boxes, see uncertain_boxes) with the predictions and detections, from which
    # the iou and coverage of its blocks follow
    uncertain = uncertain_boxes(tracks, pred, config) if n and nd else None
    seen_rows = last_seen_rows(tracks, config)
    n_seen = int(seen_rows.sum()) if uncertain is not None else 0
    if n_seen and uncertain is not None:  # the last seen boxes, one more part (recovery)
        uncertain = (uncertain[0], [*uncertain[1], (seen_rows, tracks.kf.observed()[seen_rows])])
    if uncertain is not None:
        boxes = np.concatenate([pred, dxy] + [b for _, b in uncertain[1]])
    else:
        boxes = pred if n else dxy
    inter = intersection(boxes, boxes[:nb])
    area = box_area(boxes)
    covered = safe_ratio(inter[:nb], area[:nb, None])  # geometry.coverage: i covered by j
    plain = extra = None
    if n and nd:
        # iou of every box with the detections (rows n..nb, detections with themselves,
        # are not used)
        fit = iou_from_intersection(inter[:, n:nb], area, area[n:nb])
        plain, extra = fit[:n], fit[nb:]
    # coverage by boxes in front only (geometry.in_front: 3D depth where both have one, else
    # the lower bottom of a box not cut by the border; never a box by itself)
    depth = np.concatenate([tracks.depth, dets.depth])
    cut = cut_by_border(boxes[:nb], c.image_size, c.border_margin)
    front = in_front(boxes[:nb], depth, cut)
    in_front_cov = np.where(front.T, covered, 0.0)
    lik, qlik = gate(tracks, pred, dets, config, plain, uncertain, extra)
    won = None
    if n_seen and plain is not None and extra is not None and uncertain is not None:
        lik, qlik, won = _recovered(tracks, pred, dets, config, plain, uncertain, extra, lik, qlik)
    ti, dj = np.nonzero(lik > 0)
    cand = int_columns(ti, dj, qlik[ti, dj])
    cand_exact = lik[ti, dj]
    at_last_seen = np.zeros((0, 2), dtype=np.int64)
    if won is not None:
        si, sj = np.nonzero(won)
        at_last_seen = int_columns(si, sj)
    at_all, outside_all = borders(boxes[:nb], config, area[:nb])
    at_border, outside, det_border = at_all[:n], outside_all[:n], at_all[n:]
    start_ok = dets.confidence >= c.class_gates(dets.class_id)[1]
    covers = keeps = fits = np.zeros((0, 2), dtype=np.int64)
    covers_exact = covers_margin = np.zeros(0)
    overlapped = np.zeros(n, dtype=bool)
    if n > 1:
        overlapped = in_front_cov[:n, :n].max(axis=1) >= c.partial_cover
    if n and nd:
        # an occluder is visible: measure coverage with its detection, not its prediction
        dcov = in_front_cov[:n, n:]
        back, dj = np.nonzero(dcov >= c.hide_cover)
        covers = int_columns(dj, back)
        covers_exact = dcov[back, dj]
        # whether the depth order of each pair is clear (cover_depth/3, a hiding's confidence):
        # the rule compares with depth_clear only, so two values keep the slots' universe small
        margin = front_margin(dxy[dj], pred[back], dets.depth[dj], tracks.depth[back])
        covers_margin = (margin >= c.depth_clear).astype(np.float64)
        # covering detections that fit the track as its own observation would (fits/2)
        own = qlik[back, dj] >= thresholds(config, c.iou_resume)[0]
        if c.class_aware:
            own &= tracks.cls[back] == dets.class_id[dj]
        fits = int_columns(back[own], dj[own])
        if (tracks.occluder >= 0).any():
            back, dj = np.nonzero((dcov >= c.keep_cover) & (tracks.occluder >= 0)[:, None])
            keeps = int_columns(dj, back)
    det_overlapped = np.zeros(nd, dtype=bool)
    if nd > 1:
        det_overlapped = in_front_cov[n:, n:].max(axis=1) >= c.partial_cover
    ended = expired(tracks, config)
    hid = np.flatnonzero((tracks.state == _HIDDEN) & (tracks.occluder >= 0))
    emerging = emerges(tracks, pred, dets, hid, lik, config)
    det_conf = scaled_confidence(dets.confidence, config)
    # detections too weak to start a track: still usable to continue one (conf gate in numpy)
    det_conf_fact = np.where(start_ok, np.maximum(det_conf, 1), 0)
    active = tracks.unseen == 0
    more: dict[str, np.ndarray] = {}
    if gone is not None and len(gone) and nd:
        rows, back = revival(gone, dets, config)
        if len(rows):
            table = gone.table
            more = {
                "gone_id": table.id[rows],
                "gone_how": gone.how[rows],
                "gone_class": table.cls[rows],
                "back": back,
            }
    if c.direction_weight and n and nd:
        more["moving"], more["heading"] = headings(tracks, dets, cand, config)
    if c.size_weight and n and nd:
        more["size_gap"] = size_gaps(tracks, dets, cand)
    return FrameProblem(
        track_id=tracks.id,
        active=active,
        tentative=~tracks.confirmed,
        expired=ended,
        outside=outside,
        at_border=at_border,
        overlapped=overlapped,
        track_class=tracks.cls,
        uncertain=(tracks.hits <= 1) & active,
        det_conf=det_conf_fact,
        det_class=dets.class_id,
        det_border=det_border & start_ok,
        det_overlapped=det_overlapped,
        cand=cand,
        covers=covers,
        fits=fits,
        keeps_covering=keeps,
        hidden_by=int_columns(tracks.id[hid], tracks.occluder[hid]),
        emerges=emerging,
        visibility=tracks.vis.copy(),  # the answer sets the tracks' own in place
        first_frame=first_frame,
        cand_exact=cand_exact,
        covers_exact=covers_exact,
        covers_margin=covers_margin,
        speed=speeds(tracks, config) if speed else None,
        cut=cut[:n],
        at_last_seen=at_last_seen,
        **more,
    )


def _recovered(
    tracks: TrackTable,
    pred: np.ndarray,
    dets: Detections,
    config: TrackerConfig,
    plain: np.ndarray,
    uncertain: tuple[np.ndarray, list],
    extra: np.ndarray,
    lik: np.ndarray,
    qlik: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The gate with the last seen boxes (``resume_last_seen``; their part is the last of
    ``uncertain``, its fits the last rows of ``extra``) as OC-SORT's recovery takes them: from
    detections that no other track's prediction admits. ``lik``, ``qlik``: :func:`gate` with
    every part. Returns (T, D) likelihood, its grid values and the pairs the last seen box won
    (their likelihood is that fit, better than the prediction's)."""
    n_seen = len(uncertain[1][-1][1])
    lik_p, q_p = gate(
        tracks, pred, dets, config, plain, (uncertain[0], uncertain[1][:-1]), extra[:-n_seen]
    )
    by_pred = lik_p > 0
    # a detection another track's motion explains stays theirs to contest (the recovery of
    # OC-SORT takes what its first round left): there the pair keeps its predicted fit.
    # Measured without it, hidden tracks took their occluders' detections (issue 27)
    claimed = (by_pred.sum(axis=0)[None, :] - by_pred) > 0
    lik = np.where(claimed, lik_p, lik)
    qlik = np.where(claimed, q_p, qlik)
    return lik, qlik, (lik > 0) & (qlik > q_p)


def revival(
    ended: EndedTracks, dets: Detections, config: TrackerConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Which ended tracks a detection may revive: ``(rows of ended tracks with a candidate,
    (B, 3) rows ``index into those rows, detection index, likelihood 0..1000``)``.

    Where each is looked for: with ``revive_hold`` the box where it was last seen, else its
    Kalman state (the caller predicts it on each frame); widened like an unseen track's
    prediction (``resume_growth`` per unseen frame, up to 2x), the better of the plain and the
    widened fit counts. Gated: same class, likelihood on the solver's grid at least
    ``iou_resume``, heights within ``revive_height_ratio``, detection strong enough to start
    a track."""
    c, t = config, ended.table
    box = t.kf.observed() if c.revive_hold else t.kf.xyxy()
    grow = np.minimum(1.0 + c.resume_growth * t.unseen, 2.0)
    lik = np.maximum(iou(box, dets.xyxy), iou(_widen(box, grow), dets.xyxy))
    q = quantize(config, lik)
    seen = t.kf.observed()
    h_last = (seen[:, 3] - seen[:, 1])[:, None]
    h_det = (dets.xyxy[:, 3] - dets.xyxy[:, 1])[None, :]
    ratio = safe_ratio(np.minimum(h_last, h_det), np.maximum(h_last, h_det))
    ok = (
        (t.cls[:, None] == dets.class_id[None, :])
        & (q >= thresholds(config, c.iou_resume)[0])
        & (ratio >= c.revive_height_ratio)
        & (dets.confidence >= c.class_gates(dets.class_id)[1])[None, :]
    )
    gi, dj = np.nonzero(ok)
    rows = np.unique(gi)
    local = np.searchsorted(rows, gi)
    return rows, int_columns(local, dj, q[gi, dj])


def headings(
    tracks: TrackTable, dets: Detections, cand: np.ndarray, config: TrackerConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Motion-direction consistency (OC-SORT's observation-centric momentum): ``(moving (T,)
    bool, (H, 3) rows ``track index, detection index, level 1..4``)`` over the ``cand`` rows.

    A track's direction runs from the oldest of its observations within ``direction_span_s``
    (in frames) before its last one (else the one before the last) to the last; it counts when
    the track was seen three times or more and that motion is at least ``direction_min_speed``
    box heights per second. A detection's direction runs from the track's oldest observation
    within ``direction_span_s`` of this frame (else its last) to the detection's centre. The
    level is the angle between the two in eighths of a turn, rounded; a detection nearer that
    origin than ``direction_min_speed`` would carry it counts as a quarter turn (2: neither
    along nor against the motion, charged as a moving track left unmatched)."""
    span = config.direction_span_frames
    f, xy = tracks.trail_frame, tracks.trail_xy  # (T, K) oldest first, (T, K, 2) pixels
    k = f.shape[1]
    rows = np.arange(len(tracks))
    last = f[:, -1]
    before = (f[:, :-1] >= 0) & (f[:, :-1] >= last[:, None] - span)
    anchor = np.where(before.any(axis=1), before.argmax(axis=1), k - 2)
    motion = xy[:, -1] - xy[rows, anchor]  # (T, 2) pixels
    frames = np.maximum(last - f[rows, anchor], 1)
    seen = tracks.kf.observed()
    height = np.maximum(seen[:, 3] - seen[:, 1], 1.0)
    speed = np.hypot(motion[:, 0], motion[:, 1]) / frames * config.fps / height  # heights / s
    moving = ((f >= 0).sum(axis=1) >= 3) & (speed >= config.direction_min_speed) & (speed > 0)
    pairs = cand[moving[cand[:, 0]]] if len(cand) else cand
    if not len(pairs):
        return moving, np.zeros((0, 3), dtype=np.int64)
    now = int(dets.frame[0])
    near = (f >= 0) & (f >= now - span)
    start = np.where(near.any(axis=1), near.argmax(axis=1), k - 1)
    origin = xy[rows, start]  # (T, 2)
    elapsed = np.maximum(now - f[rows, start], 1)
    t, d = pairs[:, 0], pairs[:, 1]
    centre = (dets.xyxy[d, :2] + dets.xyxy[d, 2:]) / 2
    to = centre - origin[t]
    u = motion[t]
    step = np.hypot(to[:, 0], to[:, 1])
    norm = step * np.hypot(u[:, 0], u[:, 1])
    cos = np.where(norm > 0, (u * to).sum(axis=1) / np.maximum(norm, 1e-12), 0.0)
    # a detection about where the track was: its direction is jitter, neither along nor against
    still = step / elapsed[t] * config.fps / height[t] < config.direction_min_speed
    cos = np.where(still, 0.0, cos)
    level = np.rint(np.arccos(np.clip(cos, -1.0, 1.0)) / (np.pi / 4)).astype(np.int64)
    keep = level > 0
    return moving, int_columns(t[keep], d[keep], level[keep])


def size_gaps(tracks: TrackTable, dets: Detections, cand: np.ndarray) -> np.ndarray:
    """(S, 3) rows ``track index, detection index, level 1..4`` over the ``cand`` rows of unseen
    tracks: the tenths by which the track's last observed height and the detection's differ
    (1 - smaller / larger, rounded down, at most 4; level 0 has no row)."""
    pairs = cand[tracks.unseen[cand[:, 0]] > 0] if len(cand) else cand
    if not len(pairs):
        return np.zeros((0, 3), dtype=np.int64)
    t, d = pairs[:, 0], pairs[:, 1]
    seen = tracks.kf.observed()[t]
    h_last = seen[:, 3] - seen[:, 1]
    h_det = dets.xyxy[d, 3] - dets.xyxy[d, 1]
    ratio = safe_ratio(np.minimum(h_last, h_det), np.maximum(h_last, h_det))
    level = np.minimum(np.floor((1.0 - ratio) * 10 + 1e-9), 4).astype(np.int64)
    keep = level > 0
    return int_columns(t[keep], d[keep], level[keep])


def speeds(tracks: TrackTable, config: TrackerConfig) -> np.ndarray:
    """(T,) predicted speed of each track's box centre, pixels per second (``speed/2``)."""
    v = tracks.kf.velocity()[:, :2] if len(tracks) else np.zeros((0, 2))
    return np.rint(np.hypot(v[:, 0], v[:, 1]) * config.fps).astype(np.int64)


def expired(tracks: TrackTable, config: TrackerConfig) -> np.ndarray:
    """(T,) bool: unseen tracks that would pass their time limit (hidden or missing) now."""
    c = config
    unseen = tracks.unseen > 0
    if not unseen.any():
        return unseen  # all False: every track was seen last frame
    limit = np.where(tracks.state == _HIDDEN, c.max_hidden_frames, c.max_missing_frames)
    return unseen & (tracks.unseen + 1 > limit)


def emerges(
    tracks: TrackTable,
    pred: np.ndarray,
    dets: Detections,
    hid: np.ndarray,
    lik: np.ndarray,
    config: TrackerConfig,
) -> np.ndarray:
    """(E, 2) ``detection, track`` rows: candidate detections of hidden tracks that touch the
    occluder's predicted box, widened by ``emerge_margin`` of its size on every side."""
    if not (hid.size and len(dets)):
        return np.zeros((0, 2), dtype=np.int64)
    pos = {int(t): i for i, t in enumerate(tracks.id.tolist())}
    pairs = [
        (i, pos[o])
        for i, o in zip(hid.tolist(), tracks.occluder[hid].tolist(), strict=True)
        if o in pos
    ]
    if not pairs:
        return np.zeros((0, 2), dtype=np.int64)
    hidden, occ = np.array(pairs, dtype=np.int64).T
    x1, y1, x2, y2 = pred[occ].T
    mx, my = (x2 - x1) * config.emerge_margin, (y2 - y1) * config.emerge_margin
    boxes = np.stack([x1 - mx, y1 - my, x2 + mx, y2 + my], axis=1)
    # (hidden track, detection): a candidate that touches the widened occluder box
    touch = (lik[hidden] > 0) & (intersection(boxes, dets.xyxy) > 0)
    h, d = np.nonzero(touch)
    return int_columns(d, hidden[h])


def _quantize(x: np.ndarray, levels: int, rounding=np.rint) -> np.ndarray:
    """Values in [0, 1] -> integers 0..1000 on a grid of ``levels`` steps (``np.rint``: what
    ``np.round`` calls for 0 decimals, without its Python layers)."""
    return (rounding(np.minimum(np.maximum(x, 0.0), 1.0) * levels + 1e-9) * 1000 // levels).astype(
        np.int64
    )


@lru_cache(maxsize=16)
def _floored_grid(levels: int, iou: tuple[float, ...]) -> tuple[int, ...]:
    """IoU thresholds on the solver's grid of ``levels`` steps, rounded down (asked every
    frame)."""
    return tuple(_quantize(np.array(iou), levels, np.floor).tolist())


@lru_cache(maxsize=16)
def _image_limits(
    image_size: tuple[int, int], margin: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """``margin``, the image as a (1, 4) box and ``(w - margin, h - margin)`` (asked every frame;
    shared arrays: not to be modified)."""
    w, h = image_size
    return (
        margin,
        np.array([[0.0, 0.0, w, h]]),
        np.array([w - margin, h - margin], dtype=np.float64),
    )


def int_columns(*cols: np.ndarray) -> np.ndarray:
    """``np.stack(cols, axis=1).astype(np.int64)`` for 1-d integer arrays of one length (an
    empty array and one assignment per column: fewer Python layers than np.stack)."""
    out = np.empty((len(cols[0]), len(cols)), dtype=np.int64)
    for i, col in enumerate(cols):
        out[:, i] = col
    return out


def _widen(boxes: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """(N, 4) ``xyxy`` boxes scaled about their centres by (N,) ``factor``."""
    c = (boxes[:, :2] + boxes[:, 2:]) / 2
    half = (boxes[:, 2:] - boxes[:, :2]) / 2 * factor[:, None]
    return np.concatenate([c - half, c + half], axis=1)

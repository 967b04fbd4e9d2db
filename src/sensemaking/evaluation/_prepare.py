"""Preprocessing: dataset rules applied to one sequence, ready for the metrics.

Everything is flat numpy arrays sorted by frame, with per-frame offsets. Similarities are kept
sparse: only overlapping (gt, tracker) pairs are listed (:class:`PairSet`), and a frame's dense
matrix is rebuilt only when the Hungarian solver really has to run on it (a box with two or more
candidate matches); elsewhere the candidates already are the unique optimal assignment.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from sensemaking.classes import CLASS_IDS, class_name
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.evaluation.rules import DatasetRules

EPS = float(np.finfo(float).eps)
#: IoU above which preprocessing matches a tracker box to a distractor (TrackEval: fixed 0.5)
PREPROC_THRESHOLD = 0.5
_DONTCARE = CLASS_IDS["dontcare"]

PathLike = str | os.PathLike[str] | None


def lsa():
    """scipy's ``linear_sum_assignment``, imported on first use."""
    from scipy.optimize import linear_sum_assignment

    return linear_sum_assignment


@dataclass(frozen=True, eq=False)
class PairSet:
    """The overlapping (a, b) box pairs of each frame: a sparse stack of per-frame matrices.

    Boxes of side a (ground truth) and b (tracker) are sorted by frame; frame ``t`` has a boxes
    ``a_off[t]:a_off[t + 1]`` and b boxes ``b_off[t]:b_off[t + 1]``. Only pairs with a positive
    value are listed, sorted by frame then row-major; all other entries of the per-frame
    ``(n_a_t, n_b_t)`` matrices are 0.

    Attributes:
        a_off, b_off, pair_off: (T + 1,) per-frame offsets of a boxes, b boxes and pairs.
        pf, pa, pb: (P,) frame index, a box index and b box index of each pair.
    """

    a_off: np.ndarray
    b_off: np.ndarray
    pair_off: np.ndarray
    pf: np.ndarray
    pa: np.ndarray
    pb: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.a_off.shape[0] - 1)

    @property
    def n_a(self) -> int:
        return int(self.a_off[-1])

    @property
    def n_b(self) -> int:
        return int(self.b_off[-1])

    def dense(self, t: int, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Frame ``t``'s full ``(n_a_t, n_b_t)`` matrix from the values of its pairs (zeros
        elsewhere), and the matrix of pair indices (-1 where there is no pair).

        ``values`` has one entry per pair of frame ``t`` (``pair_off[t]:pair_off[t + 1]``).
        """
        lo, hi = self.pair_off[t], self.pair_off[t + 1]
        shape = (self.a_off[t + 1] - self.a_off[t], self.b_off[t + 1] - self.b_off[t])
        rows, cols = self.pa[lo:hi] - self.a_off[t], self.pb[lo:hi] - self.b_off[t]
        out = np.zeros(shape)
        out[rows, cols] = values
        index = np.full(shape, -1, dtype=np.int64)
        index[rows, cols] = np.arange(lo, hi)
        return out, index

    def subset(self, keep_a: np.ndarray, keep_b: np.ndarray) -> tuple[PairSet, np.ndarray]:
        """Pairs among the kept boxes (boxes renumbered), and the mask of kept pairs."""
        mask = keep_a[self.pa] & keep_b[self.pb]
        new_a = np.cumsum(keep_a) - 1
        new_b = np.cumsum(keep_b) - 1
        pf = self.pf[mask]
        T = self.n_frames
        a_fi = np.repeat(np.arange(T), np.diff(self.a_off))
        b_fi = np.repeat(np.arange(T), np.diff(self.b_off))
        return PairSet(
            a_off=offsets(a_fi[keep_a], T),
            b_off=offsets(b_fi[keep_b], T),
            pair_off=offsets(pf, T),
            pf=pf,
            pa=new_a[self.pa[mask]],
            pb=new_b[self.pb[mask]],
        ), mask


@dataclass(frozen=True, eq=False)
class Prepared:
    """One sequence after preprocessing (ids relabelled 0..n-1).

    Attributes:
        n_frames: T, frames in the sequence.
        pairs: the overlapping (gt, tracker) box pairs (:class:`PairSet`; a = gt, b = tracker).
        sim: (P,) IoU of each pair (> 0).
        gt_id: (G,) contiguous gt id of each scored gt box, sorted by frame.
        tr_id: (R,) contiguous tracker id of each scored tracker box, sorted by frame.
        gt_orig_id, tr_orig_id: original id of each contiguous id.
        ign_frame, ign_gt, ign_tr: ignored gt boxes of the scored class (frame index, original gt
            id, original id of the tracker box removed because it matched it, or -1); only the
            legacy KITTI ID-switch rule uses them.
    """

    n_frames: int
    pairs: PairSet
    sim: np.ndarray
    gt_id: np.ndarray
    tr_id: np.ndarray
    gt_orig_id: np.ndarray
    tr_orig_id: np.ndarray
    ign_frame: np.ndarray
    ign_gt: np.ndarray
    ign_tr: np.ndarray

    @property
    def gt_off(self) -> np.ndarray:
        return self.pairs.a_off

    @property
    def tr_off(self) -> np.ndarray:
        return self.pairs.b_off

    @property
    def num_gt_dets(self) -> int:
        return int(self.gt_id.shape[0])

    @property
    def num_tracker_dets(self) -> int:
        return int(self.tr_id.shape[0])

    @property
    def num_gt_ids(self) -> int:
        return int(self.gt_orig_id.shape[0])

    @property
    def num_tracker_ids(self) -> int:
        return int(self.tr_orig_id.shape[0])

    @property
    def gt_frame(self) -> np.ndarray:
        """(G,) frame index of each gt box."""
        return np.repeat(np.arange(self.n_frames), np.diff(self.gt_off))


# -------------------------------------------------------------------------------------------
# small vectorised helpers


def offsets(frame_idx_sorted: np.ndarray, n_frames: int) -> np.ndarray:
    """(T + 1,) start of each frame in a frame-sorted index array."""
    return np.searchsorted(frame_idx_sorted, np.arange(n_frames + 1), side="left").astype(np.int64)


#: padded (frames x a x b) elements computed at once by :func:`overlap_pairs`
_CHUNK = 1 << 21


def _concat(parts: list[np.ndarray], dtype: type[np.generic]) -> np.ndarray:
    """Concatenate 1-D ``parts`` as ``dtype`` (an empty array of that dtype when there is none)."""
    return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype)


def overlap_pairs(
    a: np.ndarray, a_off: np.ndarray, b: np.ndarray, b_off: np.ndarray, kind: str = "iou"
) -> tuple[PairSet, np.ndarray]:
    """Same-frame pairs of corner boxes with positive IoU (or IoA: intersection / area of a).

    ``a`` (N, 4) and ``b`` (M, 4) are sorted by frame with offsets ``a_off`` / ``b_off`` (T + 1,).
    Uses TrackEval's arithmetic and degenerate-box rules (empty boxes have IoU 0). Frames are
    padded to a common size in chunks and computed by broadcasting; padding boxes are empty.
    """
    T = a_off.shape[0] - 1
    na, nb = np.diff(a_off), np.diff(b_off)
    pfs, pas, pbs, vals = [], [], [], []
    ma = int(na.max()) if T else 0
    mb = int(nb.max()) if T else 0
    if ma and mb:
        step = max(1, _CHUNK // (ma * mb))
        a_fi = np.repeat(np.arange(T), na)
        b_fi = np.repeat(np.arange(T), nb)
        a_pos = np.arange(a.shape[0]) - a_off[a_fi]
        b_pos = np.arange(b.shape[0]) - b_off[b_fi]
        for t0 in range(0, T, step):
            t1 = min(T, t0 + step)
            ca, cb = int(na[t0:t1].max()), int(nb[t0:t1].max())
            if ca == 0 or cb == 0:
                continue
            # x overlap by broadcasting over padded frames; y only where x overlaps
            A = np.zeros((2, t1 - t0, ca, 1))
            B = np.zeros((2, t1 - t0, 1, cb))
            sa = slice(a_off[t0], a_off[t1])
            sb = slice(b_off[t0], b_off[t1])
            A[:, a_fi[sa] - t0, a_pos[sa], 0] = a[sa][:, [0, 2]].T
            B[:, b_fi[sb] - t0, 0, b_pos[sb]] = b[sb][:, [0, 2]].T
            iw = np.minimum(A[1], B[1])
            iw -= np.maximum(A[0], B[0])
            iw = iw.reshape(-1)
            flat = np.flatnonzero(iw > 0)
            f, rem = np.divmod(flat, ca * cb)
            i, j = np.divmod(rem, cb)
            ga = a_off[f + t0] + i
            gb = b_off[f + t0] + j
            ih = np.minimum(a[ga, 3], b[gb, 3]) - np.maximum(a[ga, 1], b[gb, 1])
            ok = ih > 0
            pfs.append((f + t0)[ok])
            pas.append(ga[ok])
            pbs.append(gb[ok])
            vals.append(iw[flat[ok]] * ih[ok])
    pf = _concat(pfs, np.int64)
    ps = PairSet(
        a_off=a_off,
        b_off=b_off,
        pair_off=offsets(pf, T),
        pf=pf,
        pa=_concat(pas, np.int64),
        pb=_concat(pbs, np.int64),
    )
    inter = _concat(vals, np.float64)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    aa = area_a[ps.pa]
    if kind == "ioa":
        ok = aa > EPS
        value = np.where(ok, inter / np.where(ok, aa, 1.0), 0.0)
    else:
        ab = ((b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1]))[ps.pb]
        union = aa + ab - inter
        bad_union = union <= EPS
        inter = np.where((aa <= EPS) | (ab <= EPS) | bad_union, 0.0, inter)
        value = inter / np.where(bad_union, 1.0, union)
    keep = value > 0
    if not keep.all():
        pf = pf[keep]
        ps = PairSet(
            a_off=a_off,
            b_off=b_off,
            pair_off=offsets(pf, T),
            pf=pf,
            pa=ps.pa[keep],
            pb=ps.pb[keep],
        )
        value = value[keep]
    return ps, value


def conflict_frames(ps: PairSet, positive: np.ndarray) -> np.ndarray:
    """(T,) bool: frames where some box has more than one positive pair (a real assignment
    problem).

    Elsewhere the positive pairs already are the unique optimal assignment.
    """
    pa, pb, pf = ps.pa[positive], ps.pb[positive], ps.pf[positive]
    ca = np.bincount(pa, minlength=ps.n_a)
    cb = np.bincount(pb, minlength=ps.n_b)
    bad = (ca[pa] > 1) | (cb[pb] > 1)
    out = np.zeros(ps.n_frames, dtype=bool)
    out[pf[bad]] = True
    return out


def max_assignment(
    ps: PairSet,
    score: np.ndarray,
    positive: np.ndarray,
    frames_lsa: np.ndarray,
    frame_mask: np.ndarray | None = None,
) -> np.ndarray:
    """Indices of the pairs in the optimal assignment (maximum total ``score``) that are positive.

    ``positive`` pairs must be exactly those whose score could count as a match. In frames not in
    ``frames_lsa`` (no conflicts) they are returned directly; in the others scipy's Hungarian
    solver runs on the frame's full matrix (zeros for non-overlapping pairs), exactly as
    TrackEval does. ``frame_mask`` (T,) limits the result to some frames.
    """
    counts = np.diff(ps.pair_off)
    take = positive if frame_mask is None else positive & np.repeat(frame_mask, counts)
    chosen = [np.flatnonzero(take & ~np.repeat(frames_lsa, counts))]
    solve = lsa()
    lsa_mask = frames_lsa if frame_mask is None else frames_lsa & frame_mask
    for t in np.flatnonzero(lsa_mask).tolist():
        mat, index = ps.dense(t, score[ps.pair_off[t] : ps.pair_off[t + 1]])
        rows, cols = solve(-mat)
        idx = index[rows, cols]
        idx = idx[idx >= 0]  # cells without a pair score 0: never positive
        chosen.append(idx[positive[idx]])
    out = np.concatenate(chosen)
    out.sort()
    return out


# -------------------------------------------------------------------------------------------
# validation


def _line(det: Detections, i: int) -> int | None:
    assert det.source_row is not None  # Detections fills every column on construction
    row = int(det.source_row[i])
    return row if row >= 0 else None


def _fail(problem: str, det: Detections, i: int | None, path: PathLike, what: str) -> InputError:
    line = None if i is None else _line(det, i)
    if path is None:
        problem = f"{what}: {problem}"
    return InputError(problem, path, line)


def _check_boxes(det: Detections, path: PathLike, what: str) -> None:
    bad = ~np.isfinite(det.xyxy).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise _fail(f"box {det.xyxy[i].tolist()} is not finite", det, i, path, what)


def _check_frames(det: Detections, first: int, n_frames: int, path: PathLike, what: str) -> None:
    f = det.frame
    assert f is not None
    bad = (f < first) | (f >= first + n_frames)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        last = first + n_frames - 1
        raise _fail(
            f"frame {int(f[i])} is outside the sequence (frames {first}..{last}, "
            f"{n_frames} frames)",
            det,
            i,
            path,
            what,
        )


def _check_unique(
    frame_idx: np.ndarray,
    ids: np.ndarray,
    det: Detections,
    rows: np.ndarray,
    first: int,
    path: PathLike,
    what: str,
) -> None:
    """Ids must be unique within a frame (TrackEval raises too)."""
    if ids.shape[0] < 2:
        return
    order = np.lexsort((rows, ids, frame_idx))
    f, i = frame_idx[order], ids[order]
    dup = np.flatnonzero((f[1:] == f[:-1]) & (i[1:] == i[:-1]))
    if dup.size:
        k = int(rows[order[dup[0] + 1]])
        raise _fail(
            f"id {int(ids[order[dup[0]]])} occurs more than once "
            f"in frame {int(f[dup[0]]) + first}",
            det,
            k,
            path,
            what,
        )


def _column(det: Detections, key: str, default: float) -> np.ndarray:
    if key in det.data:
        return np.asarray(det.data[key], dtype=np.float64)
    return np.full(len(det), default, dtype=np.float64)


def _file_order(det: Detections) -> np.ndarray:
    """(N,) rank of each box in its source file (``source_row``), else its position.

    Within a frame boxes are taken in file order, as TrackEval reads them: the Hungarian solver
    breaks exact ties (duplicate boxes) by position, so the order can change a result.
    """
    rows = det.source_row
    assert rows is not None
    return rows if len(rows) and bool((rows >= 0).all()) else np.arange(len(det))


def infer_n_frames(gt: Detections, tracks: Detections, first: int) -> int:
    """Frames spanned by the boxes: ``max frame - first + 1`` (0 if there are none)."""
    assert gt.frame is not None and tracks.frame is not None
    last = max([first - 1] + [int(f.max()) for f in (gt.frame, tracks.frame) if len(f)])
    return last - first + 1


# -------------------------------------------------------------------------------------------


def prepare(
    gt: Detections,
    tracks: Detections,
    rules: DatasetRules,
    n_frames: int | None = None,
    gt_path: PathLike = None,
    tracks_path: PathLike = None,
) -> Prepared:
    """Apply ``rules`` to one sequence (see :mod:`sensemaking.evaluation.rules`).

    ``n_frames`` is the sequence length; boxes outside frames ``first .. first + n_frames - 1``
    raise :class:`InputError` (None: inferred from the boxes). Paths only improve error messages.
    """
    first = rules.first_frame
    assert gt.frame is not None and gt.tracker_id is not None and gt.class_id is not None
    assert tracks.frame is not None and tracks.tracker_id is not None
    assert tracks.class_id is not None
    for det, path, what in (
        (gt, gt_path, "ground truth"),
        (tracks, tracks_path, "tracker output"),
    ):
        _check_boxes(det, path, what)
        if n_frames is None:
            assert det.frame is not None
            early = det.frame < first
            if early.any():
                i = int(np.flatnonzero(early)[0])
                raise _fail(
                    f"frame {int(det.frame[i])} is before the first frame {first}",
                    det,
                    i,
                    path,
                    what,
                )
    if n_frames is None:
        n_frames = infer_n_frames(gt, tracks, first)
    for det, path, what in (
        (gt, gt_path, "ground truth"),
        (tracks, tracks_path, "tracker output"),
    ):
        _check_frames(det, first, n_frames, path, what)

    # ---- which rows take part -----------------------------------------------------------
    g_cls = gt.class_id
    g_rows = np.arange(len(gt))
    dontcare = np.zeros(len(gt), dtype=bool)
    if rules.use_dontcare:
        dontcare = g_cls == _DONTCARE
    use_g = ~dontcare
    if rules.gt_classes_used is not None:
        use_g &= np.isin(g_cls, rules.gt_classes_used)
    if rules.drop_negative_ids:
        use_g &= gt.tracker_id >= 0
    else:
        neg = np.flatnonzero(gt.tracker_id < 0)
        if neg.size:
            raise _fail(
                f"negative object id {int(gt.tracker_id[neg[0]])}",
                gt,
                int(neg[0]),
                gt_path,
                "ground truth",
            )
    if rules.valid_gt_classes is not None:
        bad = np.flatnonzero(~np.isin(g_cls, rules.valid_gt_classes))
        if bad.size:
            raise _fail(
                f"ground-truth class {int(g_cls[bad[0]])} "
                f"is not a {rules.benchmark.upper()} class (1..13); "
                f"is this {rules.benchmark.upper()} ground truth? (MOT15 has no class column)",
                gt,
                int(bad[0]),
                gt_path,
                "ground truth",
            )

    t_rows = np.arange(len(tracks))
    use_t = np.ones(len(tracks), dtype=bool)
    if rules.tracker_class is not None:
        use_t &= tracks.class_id == rules.tracker_class
    if rules.drop_negative_ids:
        use_t &= tracks.tracker_id >= 0
    else:
        neg = np.flatnonzero(tracks.tracker_id < 0)
        if neg.size:
            raise _fail(
                f"negative track id {int(tracks.tracker_id[neg[0]])} "
                "(every tracker box needs an id >= 0)",
                tracks,
                int(neg[0]),
                tracks_path,
                "tracker output",
            )
    if rules.max_tracker_class is not None and len(tracks):
        bad = np.flatnonzero(tracks.class_id > rules.max_tracker_class)
        if bad.size:
            c = int(tracks.class_id[bad[0]])
            raise _fail(
                f"{rules.benchmark.upper()} scores only pedestrians, but a track has class {c} "
                f"({class_name(c)})",
                tracks,
                int(bad[0]),
                tracks_path,
                "tracker output",
            )

    g_sel, t_sel = g_rows[use_g], t_rows[use_t]
    g_fi = gt.frame[g_sel] - first
    t_fi = tracks.frame[t_sel] - first
    go = np.lexsort((_file_order(gt)[g_sel], g_fi))
    to = np.lexsort((_file_order(tracks)[t_sel], t_fi))
    g_sel, g_fi = g_sel[go], g_fi[go]
    t_sel, t_fi = t_sel[to], t_fi[to]
    g_ids = gt.tracker_id[g_sel]
    t_ids = tracks.tracker_id[t_sel]
    if not rules.is_kitti:  # TrackEval checks MOT files before preprocessing, KITTI after
        _check_unique(g_fi, g_ids, gt, g_sel, first, gt_path, "ground truth")
        _check_unique(t_fi, t_ids, tracks, t_sel, first, tracks_path, "tracker output")
    g_off = offsets(g_fi, n_frames)
    t_off = offsets(t_fi, n_frames)
    t_xyxy = tracks.xyxy[t_sel]

    # ---- similarity of every overlapping same-frame pair ------------------------------------
    ps, sim = overlap_pairs(gt.xyxy[g_sel], g_off, t_xyxy, t_off, "iou")

    # ---- per-row flags -----------------------------------------------------------------------
    cls_sel = g_cls[g_sel]
    consider = _column(gt, "consider", 1.0)[g_sel]
    occl = _column(gt, "occluded", 0.0)[g_sel].astype(np.int64)
    trunc = _column(gt, "truncated", 0.0)[g_sel].astype(np.int64)
    in_class = (
        np.ones(g_sel.shape[0], dtype=bool)
        if rules.gt_class is None
        else cls_sel == rules.gt_class
    )
    keep_g = in_class.copy()
    if rules.use_consider_flag:
        keep_g &= consider != 0
    remove_if_matched = np.isin(cls_sel, rules.distractor_classes)
    if rules.max_occlusion is not None:
        keep_g &= occl <= rules.max_occlusion
        remove_if_matched |= occl > rules.max_occlusion + EPS
    if rules.max_truncation is not None:
        keep_g &= trunc <= rules.max_truncation
        remove_if_matched |= trunc > rules.max_truncation + EPS

    # tracker boxes removed when they match no gt box: small, or mostly inside a DontCare region
    cand_t = np.zeros(t_sel.shape[0], dtype=bool)
    if rules.min_height is not None:
        cand_t |= (t_xyxy[:, 3] - t_xyxy[:, 1]) <= rules.min_height + EPS
    if rules.use_dontcare and dontcare.any():
        d_rows = np.flatnonzero(dontcare)
        d_fi = gt.frame[d_rows] - first
        do = np.argsort(d_fi, kind="stable")
        d_rows, d_fi = d_rows[do], d_fi[do]
        qs, ioa = overlap_pairs(t_xyxy, t_off, gt.xyxy[d_rows], offsets(d_fi, n_frames), "ioa")
        cand_t[qs.pa[ioa > 0.5 + EPS]] = True

    # ---- preprocessing match: remove tracker boxes matched to distractors ---------------------
    n_g, n_t = g_sel.shape[0], t_sel.shape[0]
    removed_t = np.zeros(n_t, dtype=bool)
    ign_match_tr = np.full(n_g, -1, dtype=np.int64)
    if rules.match_distractors:
        ng, nt = np.diff(g_off), np.diff(t_off)
        per_frame_g = np.bincount(g_fi[remove_if_matched], minlength=n_frames) > 0
        per_frame_t = np.bincount(t_fi[cand_t], minlength=n_frames) > 0
        need = (per_frame_g | per_frame_t) & (ng > 0) & (nt > 0)
        matched_t = np.zeros(n_t, dtype=bool)
        if need.any():
            score = np.where(sim < PREPROC_THRESHOLD - EPS, 0.0, sim)
            positive = score > EPS
            lsa_frames = conflict_frames(ps, positive) & need
            matched = max_assignment(ps, score, positive, lsa_frames, frame_mask=need)
            mg, mt = ps.pa[matched], ps.pb[matched]
            drop = remove_if_matched[mg]
            removed_t[mt[drop]] = True
            ign_match_tr[mg[drop]] = t_ids[mt[drop]]
            matched_t[mt] = True
        removed_t |= cand_t & ~matched_t

    # ---- keep scored rows, relabel ids ------------------------------------------------------
    keep_t = ~removed_t
    kept, pair_mask = ps.subset(keep_g, keep_t)
    g_fi_k, t_fi_k = g_fi[keep_g], t_fi[keep_t]
    gk_ids, tk_ids = g_ids[keep_g], t_ids[keep_t]
    if rules.is_kitti:
        _check_unique(g_fi_k, gk_ids, gt, g_sel[keep_g], first, gt_path, "ground truth")
        _check_unique(t_fi_k, tk_ids, tracks, t_sel[keep_t], first, tracks_path, "tracker output")
    gt_orig, gt_new = np.unique(gk_ids, return_inverse=True)
    tr_orig, tr_new = np.unique(tk_ids, return_inverse=True)

    ign = in_class & ~keep_g
    return Prepared(
        n_frames=int(n_frames),
        pairs=kept,
        sim=sim[pair_mask],
        gt_id=gt_new.reshape(-1).astype(np.int64),
        tr_id=tr_new.reshape(-1).astype(np.int64),
        gt_orig_id=gt_orig.astype(np.int64),
        tr_orig_id=tr_orig.astype(np.int64),
        ign_frame=g_fi[ign].astype(np.int64),
        ign_gt=g_ids[ign].astype(np.int64),
        ign_tr=ign_match_tr[ign],
    )

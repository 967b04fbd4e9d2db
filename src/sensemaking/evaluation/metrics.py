"""CLEAR MOT, Identity, HOTA and Count metrics as pure functions, with TrackEval's field names.

Each ``*_metrics(data)`` takes one preprocessed sequence (:class:`~._prepare.Prepared`) and
returns a dict of field -> value; each ``combine_*`` sums the counts of several sequences and
recomputes the ratios, as TrackEval's ``combine_sequences`` does. Fractions are in [0, 1].

The rules are TrackEval's, including its corner cases: a sequence whose tracker (or ground
truth) is empty after preprocessing returns the counts with every ratio left at 0 (and
``MLR = 1``, ``LocA = 1``), exactly as TrackEval's early return does; combining recomputes them.

ID switches (``idsw_mode``):

- ``"trackeval"``: a matched gt object whose track id differs from the id it was last matched
  to, however long ago, is an ID switch. Frag counts the restarts of a gt object's matched run;
  as in TrackEval, frames without any gt box or without any tracker box neither break a run nor
  reset the "previous frame" whose track the matching prefers.
- ``"kitti_legacy"``: the old KITTI devkit's ``compute3rdPartyMetrics`` rules, applied to the same
  matches. Per gt trajectory (the frames where that gt object is labelled, ignored frames
  included), an ID switch is counted only when the object is tracked in this *and the previous
  labelled* frame with different ids, and never right after an ignored frame; a fragmentation is
  counted when the id differs from the previous labelled frame's (or the object was not tracked
  there) while it is tracked now, was tracked before (since the last ignored frame), and is
  tracked in the next labelled frame; and at the last labelled frame whenever it is tracked with
  an id different from the previous frame's. Matching, MT/PT/ML and everything else stay
  TrackEval's: only IDSW, Frag and the fields using IDSW (MOTA, sMOTA, MOTAL) change. (The devkit
  matches each frame without TrackEval's preference for the previous frame's track, and counts
  MT/PT/ML slightly differently; those differences are not reproduced.)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sensemaking.evaluation._prepare import EPS, Prepared, conflict_frames, lsa, max_assignment

__all__ = [
    "ALPHAS",
    "IDSW_MODES",
    "CLEAR_FIELDS",
    "IDENTITY_FIELDS",
    "HOTA_FIELDS",
    "HOTA_ARRAY_FIELDS",
    "COUNT_FIELDS",
    "clear_metrics",
    "identity_metrics",
    "hota_metrics",
    "count_metrics",
    "combine_clear",
    "combine_identity",
    "combine_hota",
    "combine_count",
]

#: HOTA localisation thresholds alpha = 0.05, 0.10, ..., 0.95 (19 values, TrackEval's exact floats)
ALPHAS = np.arange(0.05, 0.99, 0.05)
IDSW_MODES = ("trackeval", "kitti_legacy")

CLEAR_FLOAT = (
    "MOTA",
    "MOTP",
    "MODA",
    "CLR_Re",
    "CLR_Pr",
    "MTR",
    "PTR",
    "MLR",
    "sMOTA",
    "CLR_F1",
    "FP_per_frame",
    "MOTAL",
    "MOTP_sum",
)
CLEAR_INT = ("CLR_TP", "CLR_FN", "CLR_FP", "IDSW", "MT", "PT", "ML", "Frag", "CLR_Frames")
CLEAR_FIELDS = CLEAR_FLOAT + CLEAR_INT
IDENTITY_FIELDS = ("IDF1", "IDR", "IDP", "IDTP", "IDFN", "IDFP")
#: per-alpha HOTA fields: arrays of shape (19,); their scalar value is the mean over alpha
HOTA_ARRAY_FIELDS = (
    "HOTA",
    "DetA",
    "AssA",
    "DetRe",
    "DetPr",
    "AssRe",
    "AssPr",
    "LocA",
    "OWTA",
    "HOTA_TP",
    "HOTA_FN",
    "HOTA_FP",
)
HOTA_FIELDS = HOTA_ARRAY_FIELDS + ("HOTA(0)", "LocA(0)", "HOTALocA(0)")
COUNT_FIELDS = ("Dets", "GT_Dets", "IDs", "GT_IDs")

Result = dict[str, Any]


# -------------------------------------------------------------------------------------------
# CLEAR


def _clear_matches(d: Prepared, threshold: float) -> np.ndarray:
    """Indices of the matched pairs, TrackEval's CLEAR matching (prefer last frame's track)."""
    ps, sim = d.pairs, d.sim
    positive = ~(sim < threshold - EPS)
    T = d.n_frames
    lsa_frames = conflict_frames(ps, positive)
    fast = np.flatnonzero(positive & ~np.repeat(lsa_frames, np.diff(ps.pair_off)))
    if not lsa_frames.any():
        return fast
    ng, nt = np.diff(d.gt_off), np.diff(d.tr_off)
    processed = np.flatnonzero((ng > 0) & (nt > 0))
    prev_of = np.full(T, -1, dtype=np.int64)
    prev_of[processed[1:]] = processed[:-1]
    solved: dict[int, np.ndarray] = {}
    prev_tid = np.full(d.num_gt_ids, -1, dtype=np.int64)
    solve = lsa()
    po = ps.pair_off
    for t in np.flatnonzero(lsa_frames).tolist():
        p = prev_of[t]
        prev_g = np.empty(0, dtype=np.int64)
        if p >= 0:
            pm = (
                solved[p]
                if lsa_frames[p]
                else fast[np.searchsorted(fast, po[p]) : np.searchsorted(fast, po[p + 1])]
            )
            prev_g = d.gt_id[ps.pa[pm]]
            prev_tid[prev_g] = d.tr_id[ps.pb[pm]]
        lo, hi = po[t], po[t + 1]
        g_ids = d.gt_id[ps.pa[lo:hi]]
        t_ids = d.tr_id[ps.pb[lo:hi]]
        # the dense score matrix is 0 wherever sim < threshold, so only positive pairs carry it
        score = np.where(positive[lo:hi], 1000.0 * (t_ids == prev_tid[g_ids]) + sim[lo:hi], 0.0)
        mat, index = ps.dense(t, score)
        rows, cols = solve(-mat)
        idx = index[rows, cols]
        idx = idx[idx >= 0]
        solved[t] = idx[score[idx - lo] > EPS]
        prev_tid[prev_g] = -1
    out = np.concatenate([fast] + list(solved.values()))
    out.sort()
    return out


def legacy_idsw_frag(
    key: np.ndarray, frame: np.ndarray, value: np.ndarray, ignored: np.ndarray
) -> tuple[int, int]:
    """ID switches and fragmentations by the old KITTI devkit's trajectory rules.

    One entry per labelled (gt object, frame): ``key`` (E,) gt object, ``frame`` (E,), ``value``
    (E,) id of the track matched to it (-1: none), ``ignored`` (E,) bool. Per object, in frame
    order (the devkit's ``g`` and ``ign_g``): at entry f >= 1 not ignored, an ID switch when
    ``last_id != g[f] != -1``, ``last_id != -1`` and ``g[f-1] != -1``; a fragmentation when
    ``g[f-1] != g[f] != -1``, ``last_id != -1`` and (not the last entry) ``g[f+1] != -1``, or
    (the last entry) always. ``last_id`` starts as ``g[0]``, becomes -1 at an ignored entry and
    the id at a tracked one.
    """
    if key.shape[0] == 0:
        return 0, 0
    order = np.lexsort((frame, key))
    key, v, ign = key[order], value[order], ignored[order]
    n = key.shape[0]
    start = np.ones(n, dtype=bool)
    start[1:] = key[1:] != key[:-1]
    end = np.ones(n, dtype=bool)
    end[:-1] = start[1:]
    setter = start | ign | (v != -1)
    set_val = np.where(start, v, np.where(ign, -1, v))
    last_setter = np.maximum.accumulate(np.where(setter, np.arange(n), -1))
    idx = np.flatnonzero(~start)  # entries f >= 1 of a trajectory
    last = set_val[last_setter[idx - 1]]  # last_id before entry f
    cur, prev = v[idx], v[idx - 1]
    live = ~ign[idx]
    idsw = live & (last != cur) & (last != -1) & (cur != -1) & (prev != -1)
    nxt = v[np.minimum(idx + 1, n - 1)]
    frag_mid = live & ~end[idx] & (prev != cur) & (last != -1) & (cur != -1) & (nxt != -1)
    frag_end = live & end[idx] & (prev != cur) & (cur != -1)
    return int(idsw.sum()), int(frag_mid.sum() + frag_end.sum())


def _legacy_idsw_frag(d: Prepared, m_gbox: np.ndarray, m_tbox: np.ndarray) -> tuple[int, int]:
    """Legacy counts for one sequence: scored gt boxes (with their CLEAR matches) plus the
    ignored gt boxes of the scored class (with the tracker box preprocessing removed for them)."""
    value = np.full(d.num_gt_dets, -1, dtype=np.int64)
    value[m_gbox] = d.tr_orig_id[d.tr_id[m_tbox]]
    return legacy_idsw_frag(
        key=np.concatenate([d.gt_orig_id[d.gt_id], d.ign_gt]),
        frame=np.concatenate([d.gt_frame, d.ign_frame]),
        value=np.concatenate([value, d.ign_tr]),
        ignored=np.concatenate(
            [np.zeros(d.num_gt_dets, dtype=bool), np.ones(d.ign_gt.shape[0], dtype=bool)]
        ),
    )


def _clear_final(res: Result) -> Result:
    tp, fn, fp, idsw = res["CLR_TP"], res["CLR_FN"], res["CLR_FP"], res["IDSW"]
    n_ids = res["MT"] + res["ML"] + res["PT"]
    res["MTR"] = res["MT"] / max(1.0, n_ids)
    res["MLR"] = res["ML"] / max(1.0, n_ids)
    res["PTR"] = res["PT"] / max(1.0, n_ids)
    res["CLR_Re"] = tp / max(1.0, tp + fn)
    res["CLR_Pr"] = tp / max(1.0, tp + fp)
    res["MODA"] = (tp - fp) / max(1.0, tp + fn)
    res["MOTA"] = (tp - fp - idsw) / max(1.0, tp + fn)
    res["MOTP"] = res["MOTP_sum"] / max(1.0, tp)
    res["sMOTA"] = (res["MOTP_sum"] - fp - idsw) / max(1.0, tp + fn)
    res["CLR_F1"] = tp / max(1.0, tp + 0.5 * fn + 0.5 * fp)
    res["FP_per_frame"] = fp / max(1.0, res["CLR_Frames"])
    safe_log = float(np.log10(idsw)) if idsw > 0 else idsw
    res["MOTAL"] = (tp - fp - safe_log) / max(1.0, tp + fn)
    return res


def clear_metrics(d: Prepared, threshold: float = 0.5, idsw_mode: str = "trackeval") -> Result:
    """CLEAR MOT fields of one sequence (MOTA, MOTP, IDSW, Frag, MT/PT/ML, ...)."""
    if idsw_mode not in IDSW_MODES:
        raise ValueError(f"idsw_mode must be one of {IDSW_MODES}, got {idsw_mode!r}")
    res: Result = {f: 0 for f in CLEAR_INT}
    res.update({f: 0.0 for f in CLEAR_FLOAT})
    if d.num_tracker_dets == 0:
        res.update(CLR_FN=d.num_gt_dets, ML=d.num_gt_ids, MLR=1.0)
        return res
    if d.num_gt_dets == 0:
        res.update(CLR_FP=d.num_tracker_dets, MLR=1.0)
        return res

    m = _clear_matches(d, threshold)
    m_f, m_g, m_t = d.pairs.pf[m], d.pairs.pa[m], d.pairs.pb[m]
    gid, tid = d.gt_id[m_g], d.tr_id[m_t]
    tp = int(m.shape[0])
    res["CLR_TP"] = tp
    res["CLR_FN"] = d.num_gt_dets - tp
    res["CLR_FP"] = d.num_tracker_dets - tp
    res["MOTP_sum"] = float(d.sim[m].sum())
    res["CLR_Frames"] = d.n_frames

    order = np.lexsort((m_f, gid))
    gs, ts, fs = gid[order], tid[order], m_f[order]
    same = gs[1:] == gs[:-1]
    ng, nt = np.diff(d.gt_off), np.diff(d.tr_off)
    rank = np.cumsum((ng > 0) & (nt > 0)) - 1  # index among frames with both gt and tracker boxes
    rs = rank[fs]
    if idsw_mode == "trackeval":
        res["IDSW"] = int(np.count_nonzero(same & (ts[1:] != ts[:-1])))
        starts = 1 + int(np.count_nonzero(~(same & (rs[1:] == rs[:-1] + 1)))) if tp else 0
        res["Frag"] = starts - int(np.unique(gs).shape[0])
    else:
        res["IDSW"], res["Frag"] = _legacy_idsw_frag(d, m_g, m_t)

    gt_count = np.bincount(d.gt_id, minlength=d.num_gt_ids)
    matched = np.bincount(gid, minlength=d.num_gt_ids)
    present = gt_count > 0
    ratio = matched[present] / gt_count[present]
    mt = int(np.count_nonzero(ratio > 0.8))
    pt_ = int(np.count_nonzero(ratio >= 0.2)) - mt
    res.update(MT=mt, PT=pt_, ML=d.num_gt_ids - mt - pt_)
    return _clear_final(res)


def combine_clear(results: Sequence[Mapping[str, Any]]) -> Result:
    """CLEAR over several sequences: counts summed, ratios recomputed."""
    res: Result = {f: sum(r[f] for r in results) for f in CLEAR_INT}
    res["MOTP_sum"] = float(sum(r["MOTP_sum"] for r in results))
    return _clear_final(res)


# -------------------------------------------------------------------------------------------
# Identity


def _identity_final(res: Result) -> Result:
    tp, fn, fp = res["IDTP"], res["IDFN"], res["IDFP"]
    res["IDR"] = tp / max(1.0, tp + fn)
    res["IDP"] = tp / max(1.0, tp + fp)
    res["IDF1"] = tp / max(1.0, tp + 0.5 * fp + 0.5 * fn)
    return res


def identity_metrics(d: Prepared, threshold: float = 0.5) -> Result:
    """Identity fields of one sequence (IDF1, IDR, IDP, IDTP, IDFN, IDFP): one global matching."""
    res: Result = {"IDF1": 0.0, "IDR": 0.0, "IDP": 0.0, "IDTP": 0, "IDFN": 0, "IDFP": 0}
    if d.num_tracker_dets == 0:
        res["IDFN"] = d.num_gt_dets
        return res
    if d.num_gt_dets == 0:
        res["IDFP"] = d.num_tracker_dets
        return res
    G, R = d.num_gt_ids, d.num_tracker_ids
    pg, pt = d.pairs.pa, d.pairs.pb
    ok = d.sim >= threshold
    potential = (
        np.bincount(d.gt_id[pg[ok]] * R + d.tr_id[pt[ok]], minlength=G * R)
        .reshape(G, R)
        .astype(float)
    )
    gt_count = np.bincount(d.gt_id, minlength=G).astype(float)
    tr_count = np.bincount(d.tr_id, minlength=R).astype(float)
    n = G + R
    fp_mat = np.zeros((n, n))
    fn_mat = np.zeros((n, n))
    fp_mat[G:, :R] = 1e10
    fn_mat[:G, R:] = 1e10
    fn_mat[:G, :R] = gt_count[:, None]
    fn_mat[np.arange(G), R + np.arange(G)] = gt_count
    fp_mat[:G, :R] = tr_count[None, :]
    fp_mat[G + np.arange(R), np.arange(R)] = tr_count
    fn_mat[:G, :R] -= potential
    fp_mat[:G, :R] -= potential
    rows, cols = lsa()(fn_mat + fp_mat)
    res["IDFN"] = int(fn_mat[rows, cols].sum())
    res["IDFP"] = int(fp_mat[rows, cols].sum())
    res["IDTP"] = int(gt_count.sum()) - res["IDFN"]
    return _identity_final(res)


def combine_identity(results: Sequence[Mapping[str, Any]]) -> Result:
    """Identity over several sequences: counts summed, ratios recomputed."""
    return _identity_final({f: sum(r[f] for r in results) for f in ("IDTP", "IDFN", "IDFP")})


# -------------------------------------------------------------------------------------------
# HOTA


def _hota_final(res: Result) -> Result:
    tp, fn, fp = res["HOTA_TP"], res["HOTA_FN"], res["HOTA_FP"]
    res["DetRe"] = tp / np.maximum(1, tp + fn)
    res["DetPr"] = tp / np.maximum(1, tp + fp)
    res["DetA"] = tp / np.maximum(1, tp + fn + fp)
    res["HOTA"] = np.sqrt(res["DetA"] * res["AssA"])
    res["OWTA"] = np.sqrt(res["DetRe"] * res["AssA"])
    res["HOTA(0)"] = float(res["HOTA"][0])
    res["LocA(0)"] = float(res["LocA"][0])
    res["HOTALocA(0)"] = res["HOTA(0)"] * res["LocA(0)"]
    return res


def _hota_empty(n_fn: int, n_fp: int) -> Result:
    k = ALPHAS.shape[0]
    res: Result = {f: np.zeros(k) for f in HOTA_ARRAY_FIELDS}
    res["HOTA_FN"] = n_fn * np.ones(k)
    res["HOTA_FP"] = n_fp * np.ones(k)
    res["LocA"] = np.ones(k)
    res.update({"HOTA(0)": 0.0, "LocA(0)": 1.0, "HOTALocA(0)": 0.0})
    return res


def hota_metrics(d: Prepared) -> Result:
    """HOTA fields of one sequence: per-alpha arrays (19,) plus HOTA(0), LocA(0), HOTALocA(0)."""
    if d.num_tracker_dets == 0:
        return _hota_empty(d.num_gt_dets, 0)
    if d.num_gt_dets == 0:
        return _hota_empty(0, d.num_tracker_dets)
    G, R = d.num_gt_ids, d.num_tracker_ids
    ps, sim = d.pairs, d.sim
    pg, pt = ps.pa, ps.pb
    # global alignment score between ids, from the similarity normalised per frame
    row_sum = np.bincount(pg, weights=sim, minlength=d.num_gt_dets)
    col_sum = np.bincount(pt, weights=sim, minlength=d.num_tracker_dets)
    denom = col_sum[pt] + row_sum[pg] - sim
    good = denom > EPS
    sim_iou = np.zeros_like(sim)
    sim_iou[good] = sim[good] / denom[good]
    pgid, ptid = d.gt_id[pg], d.tr_id[pt]
    potential = np.bincount(pgid * R + ptid, weights=sim_iou, minlength=G * R).reshape(G, R)
    gt_count = np.bincount(d.gt_id, minlength=G).astype(float)
    tr_count = np.bincount(d.tr_id, minlength=R).astype(float)
    align = potential / (gt_count[:, None] + tr_count[None, :] - potential)

    # per-frame matching maximising alignment x similarity
    score = align[pgid, ptid] * sim
    positive = score > 0
    m = max_assignment(ps, score, positive, conflict_frames(ps, positive))
    m_sim, m_g, m_t = sim[m], pgid[m], ptid[m]

    passes = m_sim[:, None] >= ALPHAS[None, :] - EPS  # (M, 19)
    tp = passes.sum(axis=0).astype(float)
    loc_sum = (m_sim[:, None] * passes).sum(axis=0)
    keys, inv = np.unique(m_g * R + m_t, return_inverse=True)
    inv = inv.reshape(-1)
    kg, kt = keys // R, keys % R
    gc, tc = gt_count[kg], tr_count[kt]
    k = ALPHAS.shape[0]
    ass_a, ass_re, ass_pr = np.zeros(k), np.zeros(k), np.zeros(k)
    for a in range(k):
        mc = np.bincount(inv[passes[:, a]], minlength=keys.shape[0]).astype(float)
        t = max(1.0, tp[a])
        ass_a[a] = np.sum(mc * (mc / np.maximum(1, gc + tc - mc))) / t
        ass_re[a] = np.sum(mc * (mc / np.maximum(1, gc))) / t
        ass_pr[a] = np.sum(mc * (mc / np.maximum(1, tc))) / t
    res: Result = {
        "HOTA_TP": tp,
        "HOTA_FN": d.num_gt_dets - tp,
        "HOTA_FP": d.num_tracker_dets - tp,
        "AssA": ass_a,
        "AssRe": ass_re,
        "AssPr": ass_pr,
        "LocA": np.maximum(1e-10, loc_sum) / np.maximum(1e-10, tp),
    }
    return _hota_final(res)


def combine_hota(results: Sequence[Mapping[str, Any]]) -> Result:
    """HOTA over several sequences: TP/FN/FP summed per alpha, association and localisation
    averaged weighted by each sequence's TP per alpha, then the rest recomputed."""
    res: Result = {f: sum(r[f] for r in results) for f in ("HOTA_TP", "HOTA_FN", "HOTA_FP")}
    tp = res["HOTA_TP"]
    for f in ("AssRe", "AssPr", "AssA"):
        res[f] = sum(r[f] * r["HOTA_TP"] for r in results) / np.maximum(1.0, tp)
    loc = sum(r["LocA"] * r["HOTA_TP"] for r in results)
    res["LocA"] = np.maximum(1e-10, loc) / np.maximum(1e-10, tp)
    return _hota_final(res)


# -------------------------------------------------------------------------------------------
# Count


def count_metrics(d: Prepared) -> Result:
    """Numbers of scored tracker boxes, gt boxes, tracker ids and gt ids."""
    return {
        "Dets": d.num_tracker_dets,
        "GT_Dets": d.num_gt_dets,
        "IDs": d.num_tracker_ids,
        "GT_IDs": d.num_gt_ids,
    }


def combine_count(results: Sequence[Mapping[str, Any]]) -> Result:
    """Count over several sequences: sums."""
    return {f: sum(r[f] for r in results) for f in COUNT_FIELDS}

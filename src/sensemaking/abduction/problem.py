"""One frame's abduction problem: gated numpy arrays, written as ASP facts.

The vocabulary of the facts is documented in ``encodings/tracking.lp``. Gating happens here (in
numpy) so that the solver only grounds admissible pairs; the encoding's integrity constraints
state the same thresholds, so the gate is an optimisation, never a change of the answer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FrameProblem", "VISIBILITY_VALUES"]

VISIBILITY_VALUES = ("fully_visible", "partially_occluded", "fully_occluded")


def _ids(mask: np.ndarray, ids: np.ndarray) -> list[int]:
    return [int(i) for i in ids[mask]]


@dataclass
class FrameProblem:
    """Arrays over T tracks and D detections (indices, not ids, unless named ``*_id``).

    Attributes:
        track_id: (T,) int track ids.
        active: (T,) bool, matched in the previous frame.
        tentative: (T,) bool, not yet confirmed.
        uncertain: (T,) bool, seen only once: widened prediction, gated like a halted track.
        expired: (T,) bool, unobserved too long: must end.
        outside: (T,) bool, predicted box outside the field of view: must end.
        at_border: (T,) bool, predicted box touches the border.
        overlapped: (T,) bool, predicted box partly covered by a box in front.
        track_class: (T,) int class ids.
        det_conf: (D,) int confidences scaled to 0..1000.
        det_class: (D,) int class ids.
        det_border: (D,) bool, detection touches the border.
        det_overlapped: (D,) bool, detection partly covered by a detection in front.
        cand: (K, 3) int rows ``track index, detection index, likelihood 0..1000``.
        covers: (P, 2) int rows ``detection index, track index``: the detection is in front of
            the track's predicted box and covers at least the hiding fraction of it.
        keeps_covering: (Q, 2) int rows, as ``covers`` with the lower "stay hidden" fraction.
        hidden_by: (H, 2) int rows ``track id, occluder track id`` true in the previous frame.
        emerges: (E, 2) int rows ``detection index, track index``: the detection touches the box
            of the hidden track's occluder.
        visibility: (T,) int index into :data:`VISIBILITY_VALUES`, previous frame.
        first_frame: no reason is needed for objects present at the start.
        cand_exact: (K,) float likelihoods of ``cand`` before quantisation (IoU in [0, 1]), or
            None. With them the facts name a maximum-likelihood matching (``prefer/2``) that
            breaks ties between optima the quantised likelihoods cannot tell apart.
        covers_exact: (P,) float fraction of the track's predicted box covered by the detection,
            one per ``covers`` row, or None. With them the facts rank each track's covering
            detections (``cover_rank/3``): a lowest-priority tie-break between occluders that
            hide a track at the same cost.
    """

    track_id: np.ndarray
    active: np.ndarray
    tentative: np.ndarray
    expired: np.ndarray
    outside: np.ndarray
    at_border: np.ndarray
    overlapped: np.ndarray
    track_class: np.ndarray
    det_conf: np.ndarray
    det_class: np.ndarray
    det_border: np.ndarray
    det_overlapped: np.ndarray
    cand: np.ndarray
    uncertain: np.ndarray | None = None
    covers: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    keeps_covering: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    hidden_by: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    emerges: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    visibility: np.ndarray | None = None
    first_frame: bool = False
    cand_exact: np.ndarray | None = None
    covers_exact: np.ndarray | None = None

    @property
    def n_tracks(self) -> int:
        return int(self.track_id.shape[0])

    @property
    def n_dets(self) -> int:
        return int(self.det_conf.shape[0])

    def isolated_pairs(self) -> np.ndarray:
        """(K, 2) rows ``track index, detection index`` whose optimum is forced: an active,
        unexpired, inside track with exactly one candidate detection that is no other track's
        candidate, likelihood > 0, and whose detection covers no *other* track.

        With non-negative costs, assigning such a pair costs ``1000 - L < 1000``, while any
        alternative costs at least 1000 (the unmatched track) plus non-negative event costs. So
        the track never halts (its own covers facts do not matter) and the only way the pair
        touches the rest is through its detection occluding another track -- excluded here.
        """
        if self.cand.size == 0:
            return np.zeros((0, 2), dtype=np.int64)
        # plain Python over the rows: a frame has a few dozen at most, where numpy's per-call
        # cost dominates (tests/test_settle.py checks it against the array formulation)
        rows = self.cand.tolist()
        t_deg: dict[int, int] = {}
        d_deg: dict[int, int] = {}
        partner: dict[int, int] = {}  # meaningful where the detection has one candidate track
        for t, d, _ in rows:
            t_deg[t] = t_deg.get(t, 0) + 1
            d_deg[d] = d_deg.get(d, 0) + 1
            partner[d] = t
        couples = {d for rel in (self.covers, self.keeps_covering) for d, t in rel.tolist() if t != partner.get(d, -1)}
        active, expired, outside = self.active.tolist(), self.expired.tolist(), self.outside.tolist()
        pairs = [(t, d) for t, d, lik in rows
                 if t_deg[t] == 1 and d_deg[d] == 1 and lik > 0 and active[t] and not expired[t]
                 and not outside[t] and d not in couples]
        return np.array(pairs, dtype=np.int64).reshape(-1, 2)

    def forced_ignores(self) -> np.ndarray:
        """(K,) indices of detections whose only possible action is ``ignore_det``: too weak to
        start a track (confidence fact 0) and no track's candidate. Such a detection can be
        neither an occluder (that needs it matched or started) nor anything else."""
        weak = self.det_conf == 0
        if self.cand.size:
            weak[self.cand[:, 1]] = False
        return np.flatnonzero(weak)

    def preferred_pairs(self) -> np.ndarray:
        """(P, 2) rows ``track index, detection index``: a matching of maximum summed exact
        likelihood over the candidate pairs (Hungarian); empty without ``cand_exact``."""
        if self.cand_exact is None or self.cand.size == 0:
            return np.zeros((0, 2), dtype=np.int64)
        from scipy.optimize import linear_sum_assignment

        w = np.zeros((self.n_tracks, self.n_dets))
        w[self.cand[:, 0], self.cand[:, 1]] = self.cand_exact
        rows, cols = linear_sum_assignment(w, maximize=True)
        ok = w[rows, cols] > 0
        return np.stack([rows[ok], cols[ok]], axis=1).astype(np.int64)

    def cover_ranks(self) -> np.ndarray:
        """(P,) rank of each ``covers`` row among the rows of its track: 0 for the detection that
        covers the most (ties: lower detection index first), -1 for a track covered by one
        detection only (nothing to break); all -1 without ``covers_exact``."""
        ranks = np.full(len(self.covers), -1, dtype=np.int64)
        if self.covers_exact is None or len(self.covers) < 2:
            return ranks
        by_track: dict[int, list[tuple[float, int, int]]] = {}
        for row, ((d, t), c) in enumerate(zip(self.covers.tolist(), self.covers_exact.tolist())):
            by_track.setdefault(t, []).append((-c, d, row))
        for rows in by_track.values():
            if len(rows) > 1:
                for r, (_, _, row) in enumerate(sorted(rows)):
                    ranks[row] = r
        return ranks

    def subset(self, tracks: np.ndarray, dets: np.ndarray) -> FrameProblem:
        """The problem restricted to the tracks and detections whose masks are True
        (indices renumbered; relations touching a removed object are dropped)."""
        t_new = np.cumsum(tracks) - 1
        d_new = np.cumsum(dets) - 1

        def rel(rows: np.ndarray, t_col: int | None, d_col: int | None) -> np.ndarray:
            keep = np.ones(len(rows), dtype=bool)
            if t_col is not None:
                keep &= tracks[rows[:, t_col]]
            if d_col is not None:
                keep &= dets[rows[:, d_col]]
            out = rows[keep].copy()
            if t_col is not None:
                out[:, t_col] = t_new[out[:, t_col]]
            if d_col is not None:
                out[:, d_col] = d_new[out[:, d_col]]
            return out

        cand_kept = tracks[self.cand[:, 0]] & dets[self.cand[:, 1]] if len(self.cand) else np.zeros(0, bool)
        covers_kept = (tracks[self.covers[:, 1]] & dets[self.covers[:, 0]] if len(self.covers)
                       else np.zeros(0, bool))
        kept_ids = self.track_id[tracks]
        hidden = self.hidden_by[np.isin(self.hidden_by[:, 0], kept_ids)] if len(self.hidden_by) else self.hidden_by
        return FrameProblem(
            track_id=self.track_id[tracks], active=self.active[tracks], tentative=self.tentative[tracks],
            expired=self.expired[tracks], outside=self.outside[tracks], at_border=self.at_border[tracks],
            overlapped=self.overlapped[tracks], track_class=self.track_class[tracks],
            det_conf=self.det_conf[dets], det_class=self.det_class[dets], det_border=self.det_border[dets],
            det_overlapped=self.det_overlapped[dets], cand=rel(self.cand, 0, 1),
            uncertain=None if self.uncertain is None else self.uncertain[tracks],
            covers=rel(self.covers, 1, 0), keeps_covering=rel(self.keeps_covering, 1, 0),
            emerges=rel(self.emerges, 1, 0),
            hidden_by=hidden, visibility=None if self.visibility is None else self.visibility[tracks],
            first_frame=self.first_frame,
            cand_exact=None if self.cand_exact is None else self.cand_exact[cand_kept],
            covers_exact=None if self.covers_exact is None else self.covers_exact[covers_kept],
        )

    def to_facts(self) -> str:
        """The problem as ASP facts (one string; deterministic order)."""
        tid = self.track_id.astype(np.int64)
        out: list[str] = []
        add = out.append
        for t, k, a in zip(tid.tolist(), self.track_class.tolist(), self.active.tolist()):
            add(f"track({t}).ttype({t},{k}).{'active' if a else 'halted'}({t}).")
        uncertain = self.uncertain if self.uncertain is not None else np.zeros(len(tid), dtype=bool)
        for name, mask in (("tentative", self.tentative), ("uncertain", uncertain),
                           ("expired", self.expired), ("outside", self.outside),
                           ("at_border", self.at_border), ("overlapped", self.overlapped)):
            for t in _ids(mask, tid):
                add(f"{name}({t}).")
        for j, (c, k) in enumerate(zip(self.det_conf.tolist(), self.det_class.tolist())):
            add(f"det(d({j}),{c}).dtype(d({j}),{k}).")
        for j in np.flatnonzero(self.det_border).tolist():
            add(f"det_border(d({j})).")
        for j in np.flatnonzero(self.det_overlapped).tolist():
            add(f"det_overlapped(d({j})).")
        for ti, dj, lik in self.cand.tolist():
            add(f"cand({tid[ti]},d({dj}),{lik}).")
        for ti, dj in self.preferred_pairs().tolist():
            add(f"prefer({tid[ti]},d({dj})).")
        for (dj, ti), r in zip(self.covers.tolist(), self.cover_ranks().tolist()):
            add(f"covers(d({dj}),{tid[ti]}).")
            if r >= 0:
                add(f"cover_rank(d({dj}),{tid[ti]},{r}).")
        for dj, ti in self.keeps_covering.tolist():
            add(f"keeps_covering(d({dj}),{tid[ti]}).")
        for t in tid.tolist():
            add(f"holds(in_fov({t}),true,0).")
        for t, o in self.hidden_by.tolist():
            add(f"holds(hidden_by({t},{o}),true,0).")
        for dj, ti in self.emerges.tolist():
            add(f"emerges(d({dj}),{tid[ti]}).")
        if self.visibility is not None:
            for t, v in zip(tid.tolist(), self.visibility.tolist()):
                add(f"holds(visibility({t}),{VISIBILITY_VALUES[v]},0).")
        if self.first_frame:
            add("first_frame.")
        return "\n".join(out)

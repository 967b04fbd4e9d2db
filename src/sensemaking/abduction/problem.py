"""One frame's abduction problem: gated numpy arrays, cut into independent components.

The vocabulary of the facts is documented in ``encodings/tracking.lp``. Gating happens in the
tracker (numpy) so that the solver only grounds admissible pairs; the encoding's integrity
constraints state the same thresholds, so the gate is an optimisation, never a change of the
answer.

A frame falls apart into *components*: tracks and detections linked by ``cand``, ``covers``,
``keeps_covering``, ``emerges``, ``fits`` and ``back`` facts (ended tracks that may revive).
:meth:`FrameProblem.components` describes each one canonically (:class:`Component`: local
indices, so the same facts give the same key), and :meth:`Component.facts` writes its facts as
clingo symbols.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field

import numpy as np
from clingo import Symbol

from sensemaking import asp

__all__ = [
    "FrameProblem",
    "Component",
    "ComponentFields",
    "VISIBILITY_VALUES",
    "TRACK_FLAGS",
    "GONE_EVENTS",
    "SHARE_STEP",
]

VISIBILITY_VALUES = ("fully_visible", "partially_occluded", "fully_occluded")
#: how a revivable track ended (``gone/2``), by :attr:`FrameProblem.gone_how` index
GONE_EVENTS = ("leaves_fov", "ends")
#: the per-track flags of the facts, in the order of :attr:`Component.tracks` rows
TRACK_FLAGS = ("tentative", "uncertain", "expired", "outside", "at_border", "overlapped", "cut")

#: ``cover_share/3`` values are per mille rounded down to this step (``cover_depth/3`` is 0 or
#: 1000): few distinct values keep the answer cache's keys and the slot solver's universe small
#: (a step of 50 made MOT17-04 track three times slower, docs/DESIGN-NOTES.md)
SHARE_STEP = 250


def _empty_rows(width: int = 2) -> np.ndarray:
    return np.zeros((0, width), dtype=np.int64)


@dataclass(frozen=True)
class Component:
    """The canonical facts of one independent part of a frame; hashable, the cache's key.

    Tracks are numbered ``0..len(tracks)-1`` in the frame's track order, then the occluders
    named by ``hidden_by`` that lie outside the component, then its ended tracks that may
    revive (``gone``); detections ``0..len(dets)-1``.

    Attributes:
        first_frame: the ``first_frame`` fact.
        tracks: per track ``(active, tentative, uncertain, expired, outside, at_border,
            overlapped, cut, class, visibility index, speed in px/s or -1)``.
        dets: per detection ``(confidence 0..1000, class, at border, overlapped)``.
        cand: ``(track, detection, likelihood 0..1000, preferred)``.
        covers: ``(detection, track, rank or -1, share, margin)``: share of the track's
            predicted box the detection covers and how far it stands in front
            (:func:`sensemaking.geometry.front_margin`), per mille rounded down to
            :data:`SHARE_STEP`, the margin at most 1000.
        keeps_covering: ``(detection, track)``.
        emerges: ``(detection, track)``.
        hidden_by: ``(track, occluder)``.
        fits: ``(track, detection)``, a subset of the ``covers`` pairs.
        gone: per ended track that may revive ``(index into GONE_EVENTS, class)``.
        back: ``(ended track, detection, likelihood 0..1000)``, the ended track counted from 0
            in ``gone``.
        moving: tracks with a direction of motion (``direction_weight``).
        heading: ``(track, detection, level 1..4)``: eighths of a turn between a moving track's
            direction and the direction to the detection (level 0 has no row).
        size_gap: ``(track, detection, level 1..4)``: tenths by which an unseen track's last
            observed height and the detection's differ (``size_weight``; 0 has no row).
        at_last_seen: ``(track, detection)``, a subset of the ``cand`` pairs: the detection fits
            the box where the (hidden or missing) track was last seen better than its prediction.
    """

    first_frame: bool
    tracks: tuple[tuple[int, ...], ...]
    dets: tuple[tuple[int, ...], ...]
    cand: tuple[tuple[int, int, int, bool], ...]
    covers: tuple[tuple[int, int, int, int, int], ...]
    keeps_covering: tuple[tuple[int, int], ...]
    emerges: tuple[tuple[int, int], ...]
    hidden_by: tuple[tuple[int, int], ...]
    fits: tuple[tuple[int, int], ...] = ()
    gone: tuple[tuple[int, int], ...] = ()
    back: tuple[tuple[int, int, int], ...] = ()
    moving: tuple[int, ...] = ()
    heading: tuple[tuple[int, int, int], ...] = ()
    size_gap: tuple[tuple[int, int, int], ...] = ()
    at_last_seen: tuple[tuple[int, int], ...] = ()

    @property
    def n_live_refs(self) -> int:
        """Track numbers of its tracks and the occluders outside it (the ended ones follow)."""
        return max([len(self.tracks)] + [o + 1 for _, o in self.hidden_by])

    @property
    def n_refs(self) -> int:
        """Track numbers the component uses: its tracks, occluders outside it, ended tracks."""
        return self.n_live_refs + len(self.gone)

    def facts(self, uses: Collection[str] = (), t0: int = 0, d0: int = 0) -> list[Symbol]:
        """The component's facts as symbols. ``uses``: optional predicates to include
        (``speed``, ``cover_share``, ``cover_depth``: only when the encoding reads them, a fact
        no rule reads cannot change the answer).
        ``t0``, ``d0``: first track and detection number (several components in one program)."""
        out: list[Symbol] = []
        add = out.append
        fact = asp.term  # facts repeat across components and frames: each made once
        with_speed = "speed" in uses
        with_share, with_depth = "cover_share" in uses, "cover_depth" in uses

        def det(j: int) -> tuple[str, int]:
            return ("d", d0 + j)

        def track(i: int) -> int:
            return t0 + i

        for i, (active, *flags, cls, vis, speed) in enumerate(self.tracks):
            ti = track(i)
            add(fact(("track", ti)))
            add(fact(("ttype", ti, cls)))
            add(fact(("active" if active else "halted", ti)))
            for name, on in zip(TRACK_FLAGS, flags, strict=True):
                if on:
                    add(fact((name, ti)))
            add(fact(("holds", ("in_fov", ti), "true", 0)))
            add(fact(("holds", ("visibility", ti), VISIBILITY_VALUES[vis], 0)))
            if with_speed and speed >= 0:
                add(fact(("speed", ti, speed)))
        for j, (conf, cls, border, overlapped) in enumerate(self.dets):
            d = det(j)
            add(fact(("det", d, conf)))
            add(fact(("dtype", d, cls)))
            if border:
                add(fact(("det_border", d)))
            if overlapped:
                add(fact(("det_overlapped", d)))
        for t, j, lik, preferred in self.cand:
            add(fact(("cand", track(t), det(j), lik)))
            if preferred:
                add(fact(("prefer", track(t), det(j))))
        for j, t, rank, share, margin in self.covers:
            add(fact(("covers", det(j), track(t))))
            if with_share:
                add(fact(("cover_share", det(j), track(t), share)))
            if with_depth:
                add(fact(("cover_depth", det(j), track(t), margin)))
            if rank >= 0:
                add(fact(("cover_rank", det(j), track(t), rank)))
        for t, j in self.fits:
            add(fact(("fits", track(t), det(j))))
        for j, t in self.keeps_covering:
            add(fact(("keeps_covering", det(j), track(t))))
        for j, t in self.emerges:
            add(fact(("emerges", det(j), track(t))))
        for t, o in self.hidden_by:
            add(fact(("holds", ("hidden_by", track(t), track(o)), "true", 0)))
        if self.gone:
            g0 = self.n_live_refs
            for g, (how, cls) in enumerate(self.gone):
                add(fact(("gone", track(g0 + g), GONE_EVENTS[how])))
                add(fact(("ttype", track(g0 + g), cls)))
            for g, j, lik in self.back:
                add(fact(("back", track(g0 + g), det(j), lik)))
        for t in self.moving:
            add(fact(("moving", track(t))))
        for t, j, level in self.heading:
            add(fact(("heading", track(t), det(j), level)))
        for t, j, level in self.size_gap:
            add(fact(("size_gap", track(t), det(j), level)))
        for t, j in self.at_last_seen:
            add(fact(("at_last_seen", track(t), det(j))))
        if self.first_frame:
            add(fact("first_frame"))
        return out


#: a :class:`Component`'s field values in field order (``Component(*fields)`` is the component):
#: plain tuples of ints and bools, what the answer cache keys are made of
ComponentFields = tuple


@dataclass
class FrameProblem:
    """Arrays over T tracks and D detections (indices, not ids, unless named ``*_id``).

    Attributes:
        track_id: (T,) int track ids.
        active: (T,) bool, matched in the previous frame.
        tentative: (T,) bool, not yet confirmed.
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
        uncertain: (T,) bool, seen only once: widened prediction, gated like a halted track.
        covers: (P, 2) int rows ``detection index, track index``: the detection is in front of
            the track's predicted box (:func:`sensemaking.geometry.in_front`: 3D depth where both
            have one, else box bottom, never in front of a box cut by the image border) and
            covers at least the hiding fraction of it.
        fits: (F, 2) int rows ``track index, detection index``, a subset of the ``covers``
            pairs: the detection fits the track's prediction at least at the resume likelihood
            (and its class, when classes count): it could be the track's own observation.
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
            detections (``cover_rank/3``): a lowest-priority tie-break between occluders.
        covers_margin: (P,) float, 1 where the detection of each ``covers`` row stands in
            front of the track by at least ``depth_clear`` (:func:`sensemaking.geometry.
            front_margin`), else 0; or None (the ``cover_depth/3`` facts then say 1000: clear).
        speed: (T,) int predicted speed of each track's box centre, pixels per second, or None
            (the ``speed/2`` facts, for encodings that read them).
        cut: (T,) bool, predicted box reaches the left, right or bottom image border
            (:func:`sensemaking.geometry.cut_by_border`), or None (no track is).
        gone_id: (G,) int ids of the ended tracks that may revive (``revive_s``), each with at
            least one ``back`` row.
        gone_how: (G,) int index into :data:`GONE_EVENTS`: how each ended.
        gone_class: (G,) int class ids.
        back: (B, 3) int rows ``ended track index, detection index, likelihood 0..1000``.
        moving: (T,) bool, the track has a direction of motion (``direction_weight``), or None.
        heading: (H, 3) int rows ``track index, detection index, level 1..4`` over ``cand``
            pairs of moving tracks: the angle between the track's direction of motion and the
            direction to the detection, in eighths of a turn (rounded; 0 has no row).
        size_gap: (S, 3) int rows ``track index, detection index, level 1..4`` over ``cand``
            pairs of unseen tracks: tenths by which the track's last observed height and the
            detection's differ, 1 - smaller / larger, rounded down, at most 4 (0 has no row).
        at_last_seen: (S, 2) int rows ``track index, detection index``, a subset of the ``cand``
            pairs (``resume_last_seen``): the detection fits the box where the hidden or missing
            track was last seen better than its prediction; the pair's likelihood is that fit.
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
    covers: np.ndarray = field(default_factory=_empty_rows)
    fits: np.ndarray = field(default_factory=_empty_rows)
    keeps_covering: np.ndarray = field(default_factory=_empty_rows)
    hidden_by: np.ndarray = field(default_factory=_empty_rows)
    emerges: np.ndarray = field(default_factory=_empty_rows)
    visibility: np.ndarray | None = None
    first_frame: bool = False
    cand_exact: np.ndarray | None = None
    covers_exact: np.ndarray | None = None
    covers_margin: np.ndarray | None = None
    speed: np.ndarray | None = None
    cut: np.ndarray | None = None
    gone_id: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    gone_how: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    gone_class: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    back: np.ndarray = field(default_factory=lambda: _empty_rows(3))
    moving: np.ndarray | None = None
    heading: np.ndarray = field(default_factory=lambda: _empty_rows(3))
    size_gap: np.ndarray = field(default_factory=lambda: _empty_rows(3))
    at_last_seen: np.ndarray = field(default_factory=_empty_rows)

    @property
    def n_tracks(self) -> int:
        return int(self.track_id.shape[0])

    @property
    def n_dets(self) -> int:
        return int(self.det_conf.shape[0])

    def preferred_pairs(self) -> np.ndarray:
        """(P, 2) rows ``track index, detection index``: a matching of maximum summed exact
        likelihood over the candidate pairs (Hungarian); empty without ``cand_exact``."""
        if self.cand_exact is None or self.cand.size == 0:
            return _empty_rows()
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
        pairs = zip(self.covers.tolist(), self.covers_exact.tolist(), strict=True)
        for row, ((d, t), c) in enumerate(pairs):
            by_track.setdefault(t, []).append((-c, d, row))
        for rows in by_track.values():
            if len(rows) > 1:
                for r, (_, _, row) in enumerate(sorted(rows)):
                    ranks[row] = r
        return ranks

    def cover_shares(self) -> np.ndarray:
        """(P,) ``cover_share/3`` of each ``covers`` row: per mille rounded down to
        :data:`SHARE_STEP` (1000 without ``covers_exact``: every pair counts as fully covering)."""
        return _steps(self.covers_exact, len(self.covers))

    def cover_depths(self) -> np.ndarray:
        """(P,) ``cover_depth/3`` of each ``covers`` row: 1000 where the depth order is clear,
        else 0 (1000 without ``covers_margin``)."""
        return _steps(self.covers_margin, len(self.covers))

    def whole(self) -> tuple[Component, list[int], list[int]]:
        """The whole frame as one component (for checks, and encodings not known to be local)."""
        fields_, track_ids, det_rows = self.whole_fields()
        return Component(*fields_), track_ids, det_rows

    def whole_fields(self) -> tuple[ComponentFields, list[int], list[int]]:
        """:meth:`whole` with the component as its :data:`ComponentFields`."""
        everything = (list(range(self.n_tracks)), list(range(self.n_dets)))
        return self._describe([everything], [list(range(len(self.gone_id)))])[0]

    def components(self) -> list[tuple[Component, list[int], list[int]]]:
        """The independent parts of the frame: ``(component, track ids of its local tracks
        (occluders outside it included), detection rows of its local detections)``.

        No rule of ``tracking.lp`` joins atoms of two parts: its rules relate a track to a
        detection only through ``cand``, ``covers``, ``keeps_covering`` and ``emerges`` facts
        (``hidden_by`` names an occluder, which can only keep covering through such a fact), an
        ended track to a detection only through ``back``, and its weak constraints are sums
        over objects. So an optimal answer of the frame is an
        optimal answer of each part, side by side.
        """
        return [(Component(*f), ids, rows) for f, ids, rows in self.component_fields()]

    def component_fields(self) -> list[tuple[ComponentFields, list[int], list[int]]]:
        """:meth:`components` with each component as its :data:`ComponentFields` (the
        :class:`Component` is built only where it is needed: a frame's components are mostly
        answered from the cache, by these fields)."""
        nt, nd, ng = self.n_tracks, self.n_dets, len(self.gone_id)
        parent = list(range(nt + nd + ng))

        def find(x: int) -> int:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for t, d, _ in self.cand.tolist():
            parent[find(t)] = find(nt + d)
        for rel in (self.covers, self.keeps_covering, self.emerges):
            for d, t in rel.tolist():
                parent[find(t)] = find(nt + d)
        for t, d in self.fits.tolist():  # covered pairs already: for a part that stands alone
            parent[find(t)] = find(nt + d)
        for g, d, _ in self.back.tolist():
            parent[find(nt + nd + g)] = find(nt + d)
        groups: dict[int, tuple[list[int], list[int]]] = {}
        for x in range(nt + nd):
            g = groups.setdefault(find(x), ([], []))
            if x < nt:
                g[0].append(x)
            else:
                g[1].append(x - nt)
        gone: dict[int, list[int]] = {}
        for g in range(ng):  # each has a back row: its group holds a detection
            gone.setdefault(find(nt + nd + g), []).append(g)
        return self._describe(list(groups.values()), [gone.get(k, []) for k in groups])

    def _describe(
        self,
        groups: list[tuple[list[int], list[int]]],
        gone_groups: list[list[int]] | None = None,
    ) -> list[tuple[ComponentFields, list[int], list[int]]]:
        """Each group of tracks and detections (frame indices, ascending) as the fields of its
        :class:`Component`, with its track ids and detection rows. Every relation is read once
        and its rows go straight to their group in its local numbering."""
        nt = self.n_tracks
        flags = [
            self.active,
            self.tentative,
            self.uncertain if self.uncertain is not None else np.zeros(nt, dtype=bool),
            self.expired,
            self.outside,
            self.at_border,
            self.overlapped,
            self.cut if self.cut is not None else np.zeros(nt, dtype=bool),
        ]
        vis = self.visibility if self.visibility is not None else np.zeros(nt, dtype=np.int64)
        speed = self.speed if self.speed is not None else np.full(nt, -1, dtype=np.int64)
        track_rows = list(
            zip(
                *[np.asarray(f, dtype=bool).tolist() for f in flags],
                self.track_class.tolist(),
                vis.tolist(),
                speed.tolist(),
                strict=True,
            )
        )
        det_rows = list(
            zip(
                self.det_conf.tolist(),
                self.det_class.tolist(),
                np.asarray(self.det_border, dtype=bool).tolist(),
                np.asarray(self.det_overlapped, dtype=bool).tolist(),
                strict=True,
            )
        )
        n = len(groups)
        # each track's and detection's group and local index
        grp_t, loc_t = [0] * nt, [0] * nt
        grp_d, loc_d = [0] * self.n_dets, [0] * self.n_dets
        for g, (ts, ds) in enumerate(groups):
            for i, t in enumerate(ts):
                grp_t[t], loc_t[t] = g, i
            for j, d in enumerate(ds):
                grp_d[d], loc_d[d] = g, j
        cand: list[list[tuple[int, int, int, bool]]] = [[] for _ in range(n)]
        if len(self.cand):
            preferred = {(t, d) for t, d in self.preferred_pairs().tolist()}
            for t, d, lik in self.cand.tolist():
                cand[grp_t[t]].append((loc_t[t], loc_d[d], lik, (t, d) in preferred))
        # the sparse relations: a group's rows only where it has some
        covers: dict[int, list[tuple[int, ...]]] = {}
        if len(self.covers):
            rows = zip(
                self.covers.tolist(),
                self.cover_ranks().tolist(),
                self.cover_shares().tolist(),
                self.cover_depths().tolist(),
                strict=True,
            )
            for (d, t), r, share, margin in rows:
                covers.setdefault(grp_t[t], []).append((loc_d[d], loc_t[t], r, share, margin))
        pairs: dict[str, dict[int, list[tuple[int, ...]]]] = {}
        for name, rel in (
            ("keeps_covering", self.keeps_covering),
            ("emerges", self.emerges),
        ):  # (detection, track) rows
            found = pairs[name] = {}
            for d, t in rel.tolist() if len(rel) else ():
                found.setdefault(grp_t[t], []).append((loc_d[d], loc_t[t]))
        for name, rel in (("fits", self.fits), ("at_last_seen", self.at_last_seen)):
            found = pairs[name] = {}  # (track, detection) rows
            for t, d in rel.tolist() if len(rel) else ():
                found.setdefault(grp_t[t], []).append((loc_t[t], loc_d[d]))
        for name, rel in (("heading", self.heading), ("size_gap", self.size_gap)):
            found = pairs[name] = {}  # (track, detection, level) rows
            for t, d, level in rel.tolist() if len(rel) else ():
                found.setdefault(grp_t[t], []).append((loc_t[t], loc_d[d], level))
        moving: dict[int, list[int]] = {}
        if self.moving is not None:
            for t in np.flatnonzero(self.moving).tolist():
                moving.setdefault(grp_t[t], []).append(loc_t[t])
        ids = self.track_id.tolist()
        index = {t: i for i, t in enumerate(ids)}
        hidden_of: dict[int, list[tuple[int, int]]] = {}
        for tid, oid in self.hidden_by.tolist() if len(self.hidden_by) else ():
            at = index.get(tid)
            if at is not None:
                hidden_of.setdefault(grp_t[at], []).append((at, oid))
        gone_groups = gone_groups or [[] for _ in groups]
        first = bool(self.first_frame)
        # per group, the tuple of each sparse relation (most groups have none)
        sparse = [
            _by_group(rows, n)
            for rows in (
                covers,
                pairs["keeps_covering"],
                pairs["emerges"],
                pairs["fits"],
                moving,
                pairs["heading"],
                pairs["size_gap"],
                pairs["at_last_seen"],
            )
        ]
        cov, keeps, emerges, fits, mov, heading, size_gap, seen = sparse
        out: list[tuple[ComponentFields, list[int], list[int]]] = []
        for g, (ts, ds) in enumerate(groups):
            local_ids = [ids[t] for t in ts]
            hidden: list[tuple[int, int]] = []
            for t, oid in hidden_of.get(g, ()):
                o = index.get(oid)
                if o is not None and grp_t[o] == g:
                    hidden.append((loc_t[t], loc_t[o]))
                    continue
                if oid not in local_ids[len(ts) :]:
                    local_ids.append(oid)  # an occluder outside the component: named, no facts
                hidden.append((loc_t[t], len(ts) + local_ids[len(ts) :].index(oid)))
            gs = gone_groups[g]
            gone: tuple[tuple[int, int], ...] = ()
            back: tuple[tuple[int, int, int], ...] = ()
            if gs:
                gone, back = self._gone_part(gs, loc_d)
                local_ids += [int(self.gone_id[k]) for k in gs]  # numbered after the occluders
            fields_: ComponentFields = (
                first,
                tuple([track_rows[t] for t in ts]),
                tuple([det_rows[d] for d in ds]),
                tuple(cand[g]),
                cov[g],
                keeps[g],
                emerges[g],
                tuple(hidden),
                fits[g],
                gone,
                back,
                mov[g],
                heading[g],
                size_gap[g],
                seen[g],
            )
            out.append((fields_, local_ids, list(ds)))
        return out

    def _gone_part(
        self, gs: list[int], loc_d: list[int]
    ) -> tuple[tuple[tuple[int, int], ...], tuple[tuple[int, int, int], ...]]:
        """The ``gone`` and ``back`` rows of a component's ended tracks ``gs`` (frame indices,
        at least one), in its terms (``loc_d``: frame detection index -> local; a back row's
        detection is in the ended track's component)."""
        lg = {g: k for k, g in enumerate(gs)}
        gone = tuple((int(self.gone_how[g]), int(self.gone_class[g])) for g in gs)
        back = tuple((lg[g], loc_d[d], lik) for g, d, lik in self.back.tolist() if g in lg)
        return gone, back


def _by_group(rows: dict[int, list], n: int) -> list[tuple]:
    """``rows`` (group -> its rows) as a tuple of rows per group of ``n`` (empty where none)."""
    out: list[tuple] = [()] * n
    for g, found in rows.items():
        out[g] = tuple(found)
    return out


def _steps(values: np.ndarray | None, n: int) -> np.ndarray:
    """(n,) ``values`` in [0, 1] as per mille rounded down to :data:`SHARE_STEP` (all 1000
    where None)."""
    if values is None:
        return np.full(n, 1000, dtype=np.int64)
    permille = np.floor(np.clip(values, 0.0, 1.0) * 1000 + 1e-6)
    return (permille // SHARE_STEP * SHARE_STEP).astype(np.int64)

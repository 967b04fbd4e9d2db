"""Exact settlement of small independent parts of a frame's problem in Python, without clingo.

A frame's problem falls apart into connected components: tracks and detections linked by
``cand``, ``covers`` and ``keeps_covering`` facts. No rule of ``encodings/tracking.lp`` joins atoms
of two components (the occluder and keeps-occluding rules go through those facts; ``hidden_by``
names its occluder only as a constant, and the occluder can only keep covering through a
``keeps_covering`` fact) and the optimisation is a plain sum, so an optimal answer of the frame
is an optimal answer of each component, side by side.

:func:`settle` enumerates, for each small component, every answer of the encoding restricted to
it (the matching, then start or ignore of the unmatched detections that could occlude, then each
object's cheapest explanation) and evaluates the encoding's weak constraints on it. A component
is settled only if its optimum is *unique* -- up to the choice between occluders that hide a
track at the same cost, which the encoding's lowest-priority ``cover_rank/3`` tie-break makes
(mirrored here; no other tie-break is): then every optimal answer of the whole frame -- the
one clingo would return included -- contains exactly this part, so settling it in Python changes
nothing. Components with ties, or too large to enumerate, are left to the solver.

The rules mirrored here are those of ``tracking.lp``; ``tests/test_settle.py`` checks the two
against each other on random and real problems.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property

import numpy as np

from sensemaking.abduction.problem import VISIBILITY_VALUES, FrameProblem
from sensemaking.abduction.solver import Answer, encoding_constants

__all__ = ["settle"]

_FV, _PO, _FO = VISIBILITY_VALUES  # fully_visible, partially_occluded, fully_occluded

# one way to explain an object: (cost, action, events, fluents)
_Option = tuple[int, tuple, tuple, tuple]


def settle(problem: FrameProblem, constants: Mapping[str, int] | None = None,
           max_branches: int = 2048, whole: bool = False, tracks: np.ndarray | None = None,
           dets: np.ndarray | None = None) -> tuple[Answer, np.ndarray, np.ndarray]:
    """Settle every component of ``problem`` whose optimum is unique and small to enumerate.

    ``constants`` override the ``#const`` values of ``tracking.lp`` (the solver's constants).

    ``tracks``, ``dets``: masks of the objects to consider (default all): the same as settling
    ``problem.subset(tracks, dets)``, but the answer keeps ``problem``'s detection numbering.

    ``max_branches`` bounds the search per component (nodes of the branch and bound plus the
    start/ignore choices it tries). ``whole``: stop at the first component that cannot be
    settled (smallest first: quick to find) and settle nothing -- for callers that want all or
    nothing.

    Returns:
        (the answer for the settled objects, in ``problem``'s detection numbering; mask of the
        considered tracks left to the solver; mask of the considered detections left to it)
    """
    k = {**encoding_constants(), **(constants or {})}  # tracking.lp's #const, overridden
    nt, nd = problem.n_tracks, problem.n_dets
    answer = Answer(cost=0, optimal=True)
    t_rest = np.ones(nt, dtype=bool) if tracks is None else tracks.copy()
    d_rest = np.ones(nd, dtype=bool) if dets is None else dets.copy()
    if not (t_rest.any() or d_rest.any()):
        return answer, t_rest, d_rest
    # union-find over tracks 0..nt-1 and detections nt..nt+nd-1
    parent = list(range(nt + nd))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    cand = problem.cand.tolist()
    covers = problem.covers.tolist()
    keeps = problem.keeps_covering.tolist()
    emerges = problem.emerges.tolist()
    if tracks is not None or dets is not None:  # drop the relations of objects not considered
        tk, dk = t_rest.tolist(), d_rest.tolist()
        cand = [r for r in cand if tk[r[0]] and dk[r[1]]]
        covers, keeps, emerges = ([r for r in rel if dk[r[0]] and tk[r[1]]] for rel in (covers, keeps, emerges))
    emerges = {(int(d), int(t)) for d, t in emerges}
    for t, d, _ in cand:
        parent[find(t)] = find(nt + d)
    for d, t in covers + keeps:
        parent[find(t)] = find(nt + d)
    groups: dict[int, tuple[list[int], list[int]]] = {}
    for x in np.flatnonzero(np.concatenate([t_rest, d_rest])).tolist():
        g = groups.setdefault(find(x), ([], []))
        (g[0] if x < nt else g[1]).append(x if x < nt else x - nt)

    ctx = _Context(problem, k, cand, covers, keeps, emerges)
    considered = t_rest.copy(), d_rest.copy()
    for ts, ds in sorted(groups.values(), key=lambda g: len(g[0]) + len(g[1])):
        part = ctx.solve(ts, ds, max_branches)
        if part is None:
            if whole:
                return Answer(), considered[0], considered[1]
            continue
        _merge(answer, part)
        answer.cost += part.cost
        t_rest[ts] = False
        d_rest[ds] = False
    for ints in (answer.start, answer.end, answer.halt, answer.ignore_trk, answer.ignore_det):
        ints.sort()
    answer.events.sort(key=str)
    answer.fluents.sort(key=str)
    return answer, t_rest, d_rest


def _merge(answer: Answer, part: Answer) -> None:
    answer.assign.update(part.assign)
    answer.resume.update(part.resume)
    for name in ("start", "end", "halt", "ignore_trk", "ignore_det", "events", "fluents"):
        getattr(answer, name).extend(getattr(part, name))


class _Context:
    """Per-frame lookups shared by the components."""

    def __init__(self, p: FrameProblem, k: dict[str, int], cand: list, covers: list, keeps: list,
                 emerges: set[tuple[int, int]]):
        self.k = k
        self.tid = p.track_id.tolist()
        self.active = p.active.tolist()
        self.tentative = p.tentative.tolist()
        self.uncertain = p.uncertain.tolist() if p.uncertain is not None else [False] * len(self.tid)
        self.expired = p.expired.tolist()
        self.outside = p.outside.tolist()
        self.at_border = p.at_border.tolist()
        self.overlapped = p.overlapped.tolist()
        self.tclass = p.track_class.tolist()
        self.vis0 = ([VISIBILITY_VALUES[v] for v in p.visibility.tolist()] if p.visibility is not None
                     else [None] * len(self.tid))
        self.conf = p.det_conf.tolist()
        self.dclass = p.det_class.tolist()
        self.dborder = p.det_border.tolist()
        self.doverlapped = p.det_overlapped.tolist()
        self.first_frame = bool(p.first_frame)
        self.hidden0: dict[int, int] = {}  # track id -> (first) occluder
        self.n_hidden0: dict[int, int] = {}  # track id -> number of occluders
        for t, o in p.hidden_by.tolist():
            self.hidden0.setdefault(t, o)
            self.n_hidden0[t] = self.n_hidden0.get(t, 0) + 1
        self.cand: dict[int, list[tuple[int, int]]] = {}
        for t, d, lik in cand:
            self.cand.setdefault(t, []).append((d, lik))
        self.covers: dict[int, list[int]] = {}
        for d, t in covers:
            self.covers.setdefault(t, []).append(d)
        self.keeps: dict[int, list[int]] = {}
        for d, t in keeps:
            self.keeps.setdefault(t, []).append(d)
        self.covering = {d for d, _ in covers}
        self.emerges = emerges
        self._problem = p

    @cached_property
    def rank(self) -> dict[tuple[int, int], int]:
        """The encoding's cover_rank/3 as ``(detection, track) -> rank``: among occluders of equal
        cost, the covering-most wins (computed on first use: most frames never tie)."""
        p = self._problem
        return {(d, t): r for (d, t), r in zip(p.covers.tolist(), p.cover_ranks().tolist()) if r >= 0}

    # -- the component ------------------------------------------------------------------------
    def solve(self, tracks: list[int], dets: list[int], max_branches: int) -> Answer | None:
        """The component's unique optimal answer (its ``cost`` set), or None if it is tied or
        larger than ``max_branches``."""
        for t in tracks:
            if self.n_hidden0.get(self.tid[t], 0) > 1:
                return None  # a track hidden behind two: not produced by the tracker; leave it
        if not (tracks and dets) and max_branches >= 3:
            return self._lone(tracks, dets)
        return self._search(tracks, dets, max_branches)

    def _lone(self, tracks: list[int], dets: list[int]) -> Answer | None:
        """:meth:`_search` on a component of one object: a track with no candidate or a detection
        with no track (links join a track to a detection, so a component without one kind holds
        one object). Nothing to choose but its own explanation: the cheapest, if unique. The
        search would visit at most 3 nodes for it (hence ``max_branches >= 3`` in :meth:`solve`)."""
        cost, unique, ans = self._evaluate(tracks, dets, {}, set())
        if not unique:
            return None
        ans.cost = cost
        return ans

    def _search(self, tracks: list[int], dets: list[int], max_branches: int) -> Answer | None:
        """Branch and bound over the matching, then start/ignore of the occluding detections."""
        k = self.k
        allowed: dict[int, list[tuple[int, int]]] = {}
        for t in tracks:
            tid = self.tid[t]
            ok = []
            if self.expired[t] or self.outside[t]:
                allowed[t] = ok  # must end: never matched
                continue
            for d, lik in self.cand.get(t, ()):
                if lik < k["iou_resume"] or self.conf[d] < k["conf_assign"] or self.tclass[t] != self.dclass[d]:
                    continue
                if self.active[t]:
                    if lik < k["iou_assign"] and not self.uncertain[t]:
                        continue
                elif tid in self.hidden0 and (d, t) not in self.emerges:
                    continue
                # a halted track's match costs the resume event too: searched as a lower likelihood
                ok.append((d, lik if self.active[t] else lik - k["cost_resumes"]))
            allowed[t] = ok
        # costs that do not depend on the choice: each object's own, computed once
        fixed_t = {t: _cheapest(self._unmatched(t, self.tid[t], self.hidden0.get(self.tid[t]), {}, set()))[:2]
                   for t in tracks if t not in self.covers and t not in self.keeps}
        dynamic_t = [t for t in tracks if t not in fixed_t]
        startable = {d for d in dets if d in self.covering and self.conf[d] >= k["conf_start"]}
        start_cost = {d: _cheapest(self._untaken(d, True))[:2] for d in startable}
        ignore_cost = {d: self._untaken(d, False)[0][0] for d in startable}
        fixed_d = {d: _cheapest(self._untaken(d, None))[:2] for d in dets if d not in startable}
        # branch and bound over the matching, track by track, best candidates first. A track
        # costs at least its best candidate's 1000 - L, or 1000 (+ its own cost if that does
        # not depend on others) unmatched; only branches strictly worse than the best answer so
        # far are cut, so every optimum -- ties included -- is reached.
        order = sorted(tracks, key=lambda t: -len(allowed[t]))
        for t in order:
            allowed[t].sort(key=lambda x: -x[1])
        unmatched_cost = {t: 1000 + fixed_t[t][0] if t in fixed_t else 1000 for t in tracks}
        floor = [min([1000 - lik for _, lik in allowed[t]] + [unmatched_cost[t]]) for t in order]
        suffix = [0] * (len(order) + 1)
        for i in range(len(order) - 1, -1, -1):
            suffix[i] = suffix[i + 1] + floor[i]
        state = {"best": None, "n": 0, "budget": max_branches}
        m: dict[int, int] = {}
        by_det: dict[int, int] = {}

        def leaf(partial: int, unique: bool) -> bool:
            cost = partial
            for d in dets:
                if d not in by_det and d in fixed_d:
                    c, u = fixed_d[d]
                    cost += c
                    unique &= u
            free_cov = [d for d in dets if d not in by_det and d in startable]
            free_t = [t for t in dynamic_t if t not in m]
            state["budget"] -= 1 << len(free_cov)
            if len(free_cov) > 6 or state["budget"] < 0:
                return False
            for mask in range(1 << len(free_cov)):
                started = {d for b, d in enumerate(free_cov) if mask >> b & 1}
                total, uniq = cost, unique
                for d in free_cov:
                    c, u = start_cost[d] if d in started else (ignore_cost[d], True)
                    total += c
                    uniq &= u
                for t in free_t:
                    c, u, _ = _cheapest(self._unmatched(t, self.tid[t], self.hidden0.get(self.tid[t]), by_det, started))
                    total += c
                    uniq &= u
                best = state["best"]
                if best is None or total < best[0]:
                    state["best"], state["n"] = (total, dict(m), started), (1 if uniq else 2)
                elif total == best[0]:
                    state["n"] += 2
            return True

        def rec(i: int, partial: int, unique: bool) -> bool:
            state["budget"] -= 1
            if state["budget"] < 0:
                return False
            best = state["best"]
            if best is not None and partial + suffix[i] > best[0]:
                return True
            if i == len(order):
                return leaf(partial, unique)
            t = order[i]
            for d, lik in allowed[t]:
                if d not in by_det:
                    m[t], by_det[d] = d, t
                    ok = rec(i + 1, partial + 1000 - lik, unique)
                    del m[t], by_det[d]
                    if not ok:
                        return False
            u = fixed_t[t][1] if t in fixed_t else True
            return rec(i + 1, partial + unmatched_cost[t], unique and u)

        if not rec(0, 0, True):
            return None
        best, n_best = state["best"], state["n"]
        if best is None or n_best != 1:
            return None
        cost, unique, ans = self._evaluate(tracks, dets, best[1], best[2])
        if cost != best[0] or not unique:  # cannot happen: the same rules, evaluated again
            return None
        ans.cost = cost
        return ans

    def _evaluate(self, tracks: list[int], dets: list[int], m: dict[int, int],
                  started: set[int]) -> tuple[int, bool, Answer]:
        """The cheapest answer with matching ``m`` and the covering detections ``started`` starting
        (the others ignored): its cost, whether it is the only one of that cost, and the answer."""
        k = self.k
        ans = Answer()
        cost = 0
        unique = True
        by_det = {d: t for t, d in m.items()}
        lik_of = {t: dict(self.cand.get(t, ())) for t in m}
        for t in tracks:
            tid = self.tid[t]
            h0 = self.hidden0.get(tid)
            if t in m:
                d = m[t]
                cost += 1000 - lik_of[t][d]
                if self.active[t]:
                    ans.assign[tid] = d
                    unhides = False
                else:
                    ans.resume[tid] = d
                    cost += k["cost_resumes"]
                    unhides = h0 is not None
                    if unhides:
                        ans.events.append(("unhides_from_behind", (tid, h0)))
                        ans.fluents.append(("hidden_by", (tid, h0), "false"))
                    else:
                        ans.events.append(("reappears", (tid,)))
                vis = _PO if (self.overlapped[t] or unhides) else _FV
                if vis != self.vis0[t]:
                    ans.fluents.append(("visibility", (tid,), vis))
                continue
            cost += 1000
            c, u, opt = _cheapest(self._unmatched(t, tid, h0, by_det, started))
            cost += c
            unique &= u
            action, events, fluents = opt[1], opt[2], opt[3]
            getattr(ans, action).append(tid)
            ans.events.extend(events)
            ans.fluents.extend(fluents)
        for d in dets:
            if d in by_det:
                continue
            startable = d in self.covering and self.conf[d] >= k["conf_start"]
            opts = self._untaken(d, d in started if startable else None)
            c, u, opt = _cheapest(opts)
            cost += c
            unique &= u
            getattr(ans, opt[1]).append(d)
            ans.events.extend(opt[2])
            ans.fluents.extend(opt[3])
        return cost, unique, ans

    def _untaken(self, d: int, start: bool | None) -> list[_Option]:
        """The ways to explain an untaken detection: start (``start`` True), ignore (False), or
        either (None)."""
        k = self.k
        opts: list[_Option] = []
        if start is not False and self.conf[d] >= k["conf_start"]:
            name = f"d{d}"
            vis = _PO if self.doverlapped[d] else _FV
            fl = (("in_fov", (name,), "true"), ("visibility", (name,), vis))
            if self.dborder[d]:
                opts.append((k["cost_enters"], "start", (("enters_fov", (name,)),), fl))
            opts.append((0 if self.first_frame else k["cost_appears"], "start", (("starts", (name,)),), fl))
        if start is not True:
            opts.append((k["cost_ignore"] * self.conf[d] // 1000, "ignore_det", (), ()))
        return opts

    def _unmatched(self, t: int, tid: int, h0: int | None, by_det: dict[int, int],
                   started: set[int]) -> list[_Option]:
        """The ways to explain an unmatched track ``t``: end, halt or stay unobserved."""
        k = self.k
        opts: list[_Option] = []
        expired = self.expired[t]
        if self.at_border[t]:
            opts.append((0 if expired else k["cost_leaves"], "end", (("leaves_fov", (tid,)),),
                         (("in_fov", (tid,), "false"),)))
        lost = k["cost_dropped"] if self.tentative[t] else k["cost_lost"]
        opts.append((1 if expired else lost, "end", (("ends", (tid,)),), ()))
        if expired or self.outside[t]:
            return opts
        occluders: dict[int | str, int] = {}  # occluder -> its detection
        for d in self.covers.get(t, ()):
            if d in by_det:
                o = self.tid[by_det[d]]
                if o != tid:
                    occluders[o] = d
            elif d in started:
                occluders[f"d{d}"] = d
        vis0 = self.vis0[t]

        def ranked(occs: list[int | str]) -> list[int | str]:
            """The occluders left by the encoding's lowest-priority tie-break (cover_rank/3):
            hiding behind any of them costs the same, so only the best-ranked one is optimal."""
            if len(occs) > 1:
                rank = self.rank
                if all((occluders[o], t) in rank for o in occs):
                    return [min(occs, key=lambda o: rank[occluders[o], t])]
            return occs

        def hide(o: int | str, cost: int, action: str) -> _Option:
            fl = []
            if h0 is not None and h0 != o:
                fl.append(("hidden_by", (tid, h0), "false"))
            if h0 != o:
                fl.append(("hidden_by", (tid, o), "true"))
            if vis0 != _FO:
                fl.append(("visibility", (tid,), _FO))
            return (cost, action, (("hides_behind", (tid, o)),), tuple(fl))

        def missing(cost: int, action: str) -> _Option:
            fl = []
            if h0 is not None:
                fl.append(("hidden_by", (tid, h0), "false"))
                if vis0 != _FV:
                    fl.append(("visibility", (tid,), _FV))
            return (cost, action, (("missing_detections", (tid,)),), tuple(fl))

        if self.active[t]:
            if not self.tentative[t]:
                opts += [hide(o, k["cost_hides"], "halt") for o in ranked(list(occluders))]
                opts.append(missing(k["cost_missing"], "halt"))
            return opts
        if h0 is not None:
            still = any(d in by_det and self.tid[by_det[d]] == h0 and h0 != tid for d in self.keeps.get(t, ()))
            if still:
                opts.append((0, "ignore_trk", (), ()))
            else:
                opts += [hide(o, 0, "ignore_trk") for o in ranked([o for o in occluders if o != h0])]
                opts.append(missing(k["cost_missing"] + k["cost_unseen"], "ignore_trk"))
        else:
            opts += [hide(o, 0, "ignore_trk") for o in ranked(list(occluders))]
            opts.append((k["cost_unseen"], "ignore_trk", (), ()))
        return opts


def _cheapest(opts: list[_Option]) -> tuple[int, bool, _Option]:
    best = min(opts, key=lambda o: o[0])
    n = sum(1 for o in opts if o[0] == best[0])
    return best[0], n == 1, best

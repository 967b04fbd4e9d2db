"""Closed-form settlement (``abduction.settle``) against the solver: same answers, same costs.

``settle`` claims that each component it settles has a unique optimum and that it found it. On
random problems we enumerate *all* of clingo's optimal answers (``--opt-mode=optN``) and check
both halves of the claim; on real tracker frames we check that the solver's answer contains the
settled part and that the tracker's output does not depend on ``decompose``.
"""

from __future__ import annotations

import clingo
import numpy as np
import pytest

from sensemaking.abduction.problem import VISIBILITY_VALUES, FrameProblem
from sensemaking.abduction.settle import settle
from sensemaking.abduction.solver import Answer, encoding_constants, load_encoding
from sensemaking.synthetic import make_scene, occlusion_suite
from sensemaking.tracker import Tracker, TrackerConfig, _renumber_detections

ENCODING = load_encoding()
#: the constants the tracker gives the solver (confidence gates applied in numpy)
CONSTANTS = {**encoding_constants(), "iou_assign": 300, "iou_resume": 100, "conf_assign": 0, "conf_start": 1}


def optimal(problem: FrameProblem, consts: dict[str, int]) -> list[tuple[int, frozenset[str]]]:
    """Every optimal answer of the encoding, tie-breaks included: (cost without the tie-break
    levels, shown atoms)."""
    opts = ["--opt-mode=optN", "--warn=none", "0"] + [f"-c{k}={v}" for k, v in consts.items()]
    ctl = clingo.Control(opts)
    ctl.add("base", [], ENCODING + "\n" + problem.to_facts())
    ctl.ground([("base", [])])
    found: dict[frozenset[str], int] = {}

    def on_model(m: clingo.Model) -> None:
        if m.optimality_proven or not m.cost:
            found[frozenset(str(s) for s in m.symbols(shown=True))] = sum(
                c for c, p in zip(m.cost, m.priority) if p >= 0)

    assert ctl.solve(on_model=on_model).satisfiable
    return sorted(((c, a) for a, c in found.items()), key=lambda x: (x[0], sorted(x[1])))


def shown(ans: Answer) -> set[str]:
    """The answer as the encoding's shown atoms."""
    def arg(x: int | str) -> str:
        return f"d({x[1:]})" if isinstance(x, str) and x.startswith("d") else str(x)

    out = {f"assign({t},d({d}))" for t, d in ans.assign.items()}
    out |= {f"resume({t},d({d}))" for t, d in ans.resume.items()}
    out |= {f"start(d({d}))" for d in ans.start} | {f"ignore_det(d({d}))" for d in ans.ignore_det}
    out |= {f"{n}({t})" for n in ("end", "halt", "ignore_trk") for t in getattr(ans, n)}
    out |= {f"occurs({n}({','.join(map(arg, a))}))" for n, a in ans.events}
    out |= {f"value({n}({','.join(map(arg, a))}),{v})" for n, a, v in ans.fluents}
    return out


def random_problem(rng: np.random.Generator) -> FrameProblem:
    nt, nd = int(rng.integers(0, 6)), int(rng.integers(0, 6))
    ids = np.arange(1, nt + 1) * 3
    active = rng.random(nt) < 0.6
    cand = [(t, d, int(rng.choice([100, 275, 300, 500, 1000]))) for t in range(nt) for d in range(nd)
            if rng.random() < 0.5]
    covers = [(d, t) for d in range(nd) for t in range(nt) if rng.random() < 0.3]
    keeps = [(d, t) for d in range(nd) for t in range(nt) if rng.random() < 0.2]
    hidden = [(int(ids[t]), int(rng.choice(np.append(ids, 99)))) for t in range(nt)
              if not active[t] and rng.random() < 0.6]
    hidden = [(t, o) for t, o in hidden if t != o]
    hidden_idx = {int(np.flatnonzero(ids == t)[0]) for t, _ in hidden}
    emerges = [(d, t) for t, d, _ in cand if t in hidden_idx and rng.random() < 0.6]

    def rows(x: list, k: int) -> np.ndarray:
        return np.array(x, dtype=np.int64).reshape(-1, k)

    flag = lambda n, p: rng.random(n) < p  # noqa: E731
    # coverages with ties half of the time (the tie-break falls back to the detection index)
    covers_exact = rng.choice([0.5, 0.7, 0.7, 0.9], len(covers)) if rng.random() < 0.5 else None
    return FrameProblem(
        track_id=ids, active=active, tentative=flag(nt, 0.2), expired=~active & flag(nt, 0.2),
        outside=flag(nt, 0.1), at_border=flag(nt, 0.3), overlapped=flag(nt, 0.3),
        track_class=rng.integers(1, 3, nt) if rng.random() < 0.3 else np.ones(nt, np.int64),
        uncertain=active & flag(nt, 0.2),
        det_conf=rng.choice([0, 25, 400, 650, 675, 1000], nd), det_class=np.ones(nd, np.int64),
        det_border=flag(nd, 0.3), det_overlapped=flag(nd, 0.3), cand=rows(cand, 3),
        covers=rows(covers, 2), keeps_covering=rows(keeps, 2), hidden_by=rows(hidden, 2),
        emerges=rows(emerges, 2), visibility=rng.integers(0, len(VISIBILITY_VALUES), nt),
        first_frame=bool(rng.random() < 0.1), covers_exact=covers_exact,
    )


@pytest.mark.parametrize("costs", [{}, {"cost_unseen": 0, "cost_hides": 0, "cost_leaves": 600, "cost_dropped": 600,
                                      "cost_resumes": 0}, {"cost_resumes": 170}])
def test_settled_components_are_the_unique_optimum_on_random_problems(costs):
    consts = {**CONSTANTS, **costs}
    rng = np.random.default_rng(3)
    whole = partial = refused = 0
    for _ in range(400):
        problem = random_problem(rng)
        models = optimal(problem, consts)
        best = [a for c, a in models if c == models[0][0]]
        ans, t_rest, d_rest = settle(problem, consts)
        mine = shown(ans)
        for atoms in best:  # every optimal answer holds the settled part
            assert mine <= atoms, (problem.to_facts(), sorted(mine), [sorted(b) for b in best])
        if not t_rest.any() and not d_rest.any():
            assert len(best) == 1 and mine == best[0] and ans.cost == models[0][0], problem.to_facts()
            whole += 1
        elif t_rest.all() and d_rest.all():
            refused += 1
        else:
            partial += 1
    assert whole > 100 and partial + refused > 20, (whole, partial, refused)


def _behind_two_new_occluders(**extra) -> FrameProblem:
    """A missing track behind two new occluders: hiding behind either is free."""
    return FrameProblem(
        track_id=np.array([5]), active=np.array([False]), tentative=np.array([False]),
        expired=np.array([False]), outside=np.array([False]), at_border=np.array([False]),
        overlapped=np.array([False]), track_class=np.array([1]), det_conf=np.array([900, 900]),
        det_class=np.array([1, 1]), det_border=np.array([False, False]), det_overlapped=np.array([False, False]),
        cand=np.zeros((0, 3), np.int64), covers=np.array([[0, 0], [1, 0]]), visibility=np.array([0]), **extra,
    )


def test_ties_are_left_to_the_solver():
    # without coverages nothing prefers one occluder
    p = _behind_two_new_occluders()
    ans, t_rest, d_rest = settle(p, CONSTANTS)
    assert t_rest.all() and d_rest.all() and not ans.events
    assert len({a for c, a in optimal(p, CONSTANTS) if c == optimal(p, CONSTANTS)[0][0]}) == 2


def test_occluder_ties_are_broken_by_coverage():
    # with them the track hides behind the detection covering most, in settle as in the solver
    p = _behind_two_new_occluders(covers_exact=np.array([0.6, 0.8]))
    ans, t_rest, d_rest = settle(p, CONSTANTS)
    assert not t_rest.any() and not d_rest.any()
    assert ("hides_behind", (5, "d1")) in ans.events
    models = optimal(p, CONSTANTS)
    assert len(models) == 1 and shown(ans) == models[0][1]


def test_enumeration_budget_leaves_big_components_to_the_solver():
    n = 6
    p = FrameProblem(
        track_id=np.arange(1, n + 1), active=np.ones(n, bool), tentative=np.zeros(n, bool),
        expired=np.zeros(n, bool), outside=np.zeros(n, bool), at_border=np.zeros(n, bool),
        overlapped=np.zeros(n, bool), track_class=np.ones(n, np.int64), det_conf=np.full(n, 900),
        det_class=np.ones(n, np.int64), det_border=np.zeros(n, bool), det_overlapped=np.zeros(n, bool),
        cand=np.array([[t, d, 500] for t in range(n) for d in range(n)]), visibility=np.zeros(n, np.int64),
    )
    _, t_rest, d_rest = settle(p, CONSTANTS, max_branches=100)
    assert t_rest.all() and d_rest.all()


def _frames_of_scenes():
    dense = make_scene(30, n_frames=40, overlap=0.5, seed=7, miss_rate=0.1, false_positive_rate=0.3)
    yield dense, {"min_confidence": 0.2, "start_confidence": 0.6}
    for seed in (0, 1):
        for scene in occlusion_suite(seed):
            yield scene, {}


def test_settlement_agrees_with_the_solver_on_real_frames():
    """On every frame of a dense scene and the occlusion suite, the solver's answer to the whole
    problem contains what settle settles, at the same cost where settle settles everything."""
    settled = whole = 0
    for scene, extra in _frames_of_scenes():
        t = Tracker(TrackerConfig(fps=scene.fps, image_size=(scene.width, scene.height), **extra))
        for f, dets in scene.frames():
            pred = t._kf.copy().predict(1) if len(t._kf) else np.zeros((0, 4))
            problem = t._problem(pred, dets)
            ans, t_rest, d_rest = settle(problem, t._solver.constants)
            full = t._solver.solve(problem)
            assert shown(ans) <= shown(full), (scene.name, f)
            if not t_rest.any() and not d_rest.any():
                assert ans.cost == full.cost, (scene.name, f)
                whole += 1
            settled += int((~t_rest).sum() + (~d_rest).sum())
            t.update(dets, frame=f)
    assert whole > 50 and settled > 500, (whole, settled)


def _outputs(scene, **config) -> list[tuple]:
    t = Tracker(TrackerConfig(fps=scene.fps, image_size=(scene.width, scene.height), **config))
    out = []
    for f, dets in scene.frames():
        r = t.update(dets, frame=f)
        out.append((r.events, r.tracks.tracker_id.tolist(), r.tracks.xyxy.tolist(),
                    {k: np.asarray(v).tolist() for k, v in r.tracks.data.items()}))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tracker_output_does_not_depend_on_decomposition(seed):
    for scene in occlusion_suite(seed):
        assert _outputs(scene) == _outputs(scene, decompose=False), scene.name


def test_empty_problem_settles_to_the_empty_answer():
    p = FrameProblem(
        track_id=np.zeros(0, np.int64), active=np.zeros(0, bool), tentative=np.zeros(0, bool),
        expired=np.zeros(0, bool), outside=np.zeros(0, bool), at_border=np.zeros(0, bool),
        overlapped=np.zeros(0, bool), track_class=np.zeros(0, np.int64), det_conf=np.zeros(0, np.int64),
        det_class=np.zeros(0, np.int64), det_border=np.zeros(0, bool), det_overlapped=np.zeros(0, bool),
        cand=np.zeros((0, 3), np.int64),
    )
    ans, t_rest, d_rest = settle(p)
    assert shown(ans) == set() and t_rest.size == 0 and d_rest.size == 0


def test_masks_settle_the_same_as_the_subset():
    rng = np.random.default_rng(11)
    for _ in range(200):
        problem = random_problem(rng)
        tracks, dets = rng.random(problem.n_tracks) < 0.7, rng.random(problem.n_dets) < 0.7
        ans, t_rest, d_rest = settle(problem, CONSTANTS, tracks=tracks, dets=dets)
        sub, st_rest, sd_rest = settle(problem.subset(tracks, dets), CONSTANTS)
        index = np.flatnonzero(dets)
        assert shown(ans) == shown(_renumber_detections(sub, index))
        assert t_rest[tracks].tolist() == st_rest.tolist() and not t_rest[~tracks].any()
        assert d_rest[dets].tolist() == sd_rest.tolist() and not d_rest[~dets].any()


def _isolated_pairs_arrays(p: FrameProblem) -> np.ndarray:
    """FrameProblem.isolated_pairs in its former array formulation (the reference)."""
    if p.cand.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    ti, dj, lik = p.cand[:, 0], p.cand[:, 1], p.cand[:, 2]
    t_deg = np.bincount(ti, minlength=p.n_tracks)
    d_deg = np.bincount(dj, minlength=p.n_dets)
    ok = (t_deg[ti] == 1) & (d_deg[dj] == 1) & (lik > 0)
    ok &= p.active[ti] & ~p.expired[ti] & ~p.outside[ti]
    partner = np.full(p.n_dets, -1, dtype=np.int64)
    partner[dj] = ti
    couples = np.zeros(p.n_dets, dtype=bool)
    for rel in (p.covers, p.keeps_covering):
        if len(rel):
            other = rel[:, 1] != partner[rel[:, 0]]
            couples[rel[other, 0]] = True
    ok &= ~couples[dj]
    return np.stack([ti[ok], dj[ok]], axis=1)


def test_isolated_pairs_match_the_array_formulation():
    rng = np.random.default_rng(11)
    found = 0
    for _ in range(3000):
        p = random_problem(rng)
        if rng.random() < 0.5:  # sparser frames: more isolated pairs
            p.cand = p.cand[rng.random(len(p.cand)) < 0.4]
            p.covers, p.keeps_covering = p.covers[:int(rng.integers(0, 2))], p.keeps_covering[:0]
        got, want = p.isolated_pairs(), _isolated_pairs_arrays(p)
        assert got.dtype == want.dtype and got.shape == want.shape and np.array_equal(got, want)
        found += len(got)
    assert found > 300


def test_lone_objects_are_settled_as_the_search_settles_them():
    """settle's shortcut for one-object components (a track with no candidate, a detection with
    no track) gives the general search's answer, refusals included."""
    from sensemaking.abduction.settle import _Context

    rng = np.random.default_rng(17)
    checked = refused = 0
    tied = {**CONSTANTS, "cost_leaves": 600}  # leaving at the border costs as much as ending
    for i in range(1500):
        p = random_problem(rng)
        ctx = _Context(p, tied if i % 2 else CONSTANTS, p.cand.tolist(), p.covers.tolist(), p.keeps_covering.tolist(),
                       {(d, t) for d, t in p.emerges.tolist()})
        linked_t = set(p.cand[:, 0].tolist()) | set(p.covers[:, 1].tolist()) | set(p.keeps_covering[:, 1].tolist())
        linked_d = set(p.cand[:, 1].tolist()) | set(p.covers[:, 0].tolist()) | set(p.keeps_covering[:, 0].tolist())
        lone = [([t], []) for t in range(p.n_tracks) if t not in linked_t]
        lone += [([], [d]) for d in range(p.n_dets) if d not in linked_d]
        for ts, ds in lone:
            fast, full = ctx.solve(ts, ds, 2048), ctx._search(ts, ds, 2048)
            assert (fast is None) == (full is None)
            if fast is not None:
                assert shown(fast) == shown(full) and fast.cost == full.cost
                checked += 1
            else:
                refused += 1
    assert checked > 300 and refused > 0, (checked, refused)

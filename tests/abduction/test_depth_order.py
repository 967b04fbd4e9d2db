"""Depth order of the occlusion facts: a box cut by the image border, 3D depth over box bottom,
and no track hidden behind its own successor (issue 15, item 2)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import optimal

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.geometry import cut_by_border, in_front
from sensemaking.reasoning.relations import pair_front
from sensemaking.tracker import Tracker, TrackerConfig

CAR = CLASS_IDS["car"]
SIZE = (1242, 375)


def frame(*boxes, depth=None) -> Detections:
    data = {} if depth is None else {"location": np.array([[0.0, 1.5, z] for z in depth])}
    return Detections(np.array(boxes, dtype=float), confidence=0.9, class_id=CAR, data=data)


def run(frames: list[Detections], **config) -> list[tuple[int, str, tuple]]:
    t = Tracker(TrackerConfig(fps=10, image_size=SIZE, **config))
    out = []
    for f, dets in enumerate(frames):
        out += [(f, e.name, e.args) for e in t.update(dets, frame=f).events]
    return out


# a near car cut by the right border, leaving the view (its box shrinks to the border), and a
# far car in front of it *by box bottom* (320 > 300) that covers most of its predicted box
NEAR = [[900.0 + 20 * f, 100.0, 1242.0, 300.0] for f in range(5)]
FAR = [980.0, 120.0, 1220.0, 320.0]


def test_near_car_cut_by_the_border_leaves_the_view_rather_than_hides():
    frames = [frame(NEAR[f], FAR) for f in range(5)] + [frame(FAR)]
    events = run(frames)
    last = [(name, args) for f, name, args in events if f == 5]
    assert ("leaves_fov", (1,)) in last
    assert not any(name == "hides_behind" for name, _ in last)


def test_same_car_away_from_the_border_hides_behind_the_box_in_front():
    # the control case: the same geometry shifted left of the border, so the near car's
    # bottom is known and the far car's lower bottom puts it in front
    shift = [[x1 - 300, y1, x2 - 300, y2] for x1, y1, x2, y2 in NEAR]
    far = [FAR[0] - 300, FAR[1], FAR[2] - 300, FAR[3]]
    frames = [frame(shift[f], far) for f in range(5)] + [frame(far)]
    last = [(name, args) for f, name, args in run(frames) if f == 5]
    assert ("hides_behind", (1, 2)) in last


def test_3d_depth_wins_over_box_bottom_in_the_tracker():
    # car 1 is far (z = 30 m) but its box bottom is lower than car 2's (z = 8 m): by box bottom
    # 2 would hide behind 1; by depth 1 is behind 2, so 2 cannot hide behind it
    a = [400.0, 150.0, 600.0, 330.0]
    b = [[430.0 + 2 * f, 140.0, 610.0 + 2 * f, 310.0] for f in range(6)]
    frames = [frame(a, b[f], depth=[30.0, 8.0]) for f in range(5)] + [frame(a, depth=[30.0])]
    last = [(name, args) for f, name, args in run(frames) if f == 5]
    assert not any(name == "hides_behind" for name, _ in last)
    # without depths the same boxes give the box-bottom answer: 2 hides behind 1
    frames = [frame(a, b[f]) for f in range(5)] + [frame(a)]
    last = [(name, args) for f, name, args in run(frames) if f == 5]
    assert ("hides_behind", (2, 1)) in last


def test_in_front_rules():
    boxes = np.array([[0, 0, 10, 50], [0, 0, 10, 40], [0, 0, 10, 60]], dtype=float)
    front = in_front(boxes)
    assert front.tolist() == [[False, True, False], [False, False, False], [True, True, False]]
    # box 2 cut by the border: nothing is in front of it, it is still in front of the others
    cut = np.array([False, False, True])
    assert in_front(boxes, cut=cut).tolist() == [
        [False, True, False],
        [False, False, False],
        [True, True, False],
    ]
    cut = np.array([True, False, False])
    assert in_front(boxes, cut=cut)[:, 0].tolist() == [False, False, False]
    # depth where both have one, box bottom otherwise
    depth = np.array([5.0, 3.0, np.nan])
    got = in_front(boxes, depth=depth)
    assert got[1, 0] and not got[0, 1]  # 3 m in front of 5 m, though its bottom is higher
    assert got[2, 0] and got[2, 1]  # no depth for box 2: box bottom
    assert not got.diagonal().any()


def test_cut_by_border_counts_left_right_bottom_not_top():
    boxes = np.array(
        [[0, 50, 10, 60], [100, 0, 200, 60], [1235, 50, 1242, 60], [100, 50, 200, 370]],
        dtype=float,
    )
    assert cut_by_border(boxes, SIZE, 10.0).tolist() == [True, False, True, True]
    assert not cut_by_border(boxes, None).any()


def test_gate_and_relations_agree_where_box_bottom_and_depth_disagree():
    # box 0 lower in the image (bottom 330) but 30 m away; box 1 at 8 m
    boxes = np.array([[400, 150, 600, 330], [430, 140, 610, 310]], dtype=float)
    depth = np.array([30.0, 8.0])
    pairs = np.array([[0, 1]])
    assert pair_front(boxes, pairs).tolist() == [1]  # box bottom alone: 0 in front
    assert pair_front(boxes, pairs, depth).tolist() == [-1]  # depth: 1 in front
    # the tracker's facts use the same function: the detection 1 (nearer) covers track 0
    t = Tracker(TrackerConfig(fps=10, image_size=SIZE))
    t.update(frame(*boxes, depth=list(depth)), frame=0)
    problem = t.problem(frame(*boxes, depth=list(depth)), t.tracks.kf.predict(1))
    covers = {(int(d), int(k)) for d, k in problem.covers.tolist()}
    assert (1, 0) in covers and (0, 1) not in covers
    # detections without depth: box bottom decides, in the tracker as in pair_front
    problem = t.problem(frame(*boxes), t.tracks.kf.predict(1))
    covers = {(int(d), int(k)) for d, k in problem.covers.tolist()}
    assert (0, 1) in covers and (1, 0) not in covers


# ---- the successor rule of tracking.lp, on tiny programs ----------------------------------
def _track(t: int, *flags: str) -> str:
    out = [
        f"track({t}).",
        f"ttype({t},1).",
        f"holds(in_fov({t}),true,0).",
        f"holds(visibility({t}),fully_visible,0).",
    ]
    return " ".join(out + [f"{f}({t})." for f in flags])


def _det(j: int) -> str:
    return f"det(d({j}),900). dtype(d({j}),1)."


def _events(facts: str, consts: dict[str, int] | None = None) -> list[list[str]]:
    """The occurs/1 atoms of every optimal answer."""
    return [[a for a in atoms if a.startswith("occurs(")] for _, atoms in optimal(facts, consts)]


def test_a_track_never_hides_behind_a_new_track_started_from_its_own_observation():
    # track 1 halts; d(0) covers it and starts a new track: without fits/2 it is an occluder
    base = _track(1, "active") + _det(0) + "covers(d(0),1)."
    assert all("occurs(hides_behind(1,d(0)))" in ev for ev in _events(base))
    # d(0) fits track 1 (its own observation under a new name): never an occluder, even if
    # hiding were free and the missing detections dear
    facts = base + "fits(1,d(0))."
    for consts in (None, {"cost_hides": 0, "cost_missing": 5000}):
        for ev in _events(facts, consts):
            assert not any(a.startswith("occurs(hides_behind(1,") for a in ev)


def test_a_track_never_hides_behind_a_tentative_successor_but_may_behind_a_confirmed_track():
    # track 1 unseen (halted, not hidden); track 2 took d(0), which covers and fits track 1
    fits = "covers(d(0),1). fits(1,d(0)). cand(2,d(0),900)."
    young = _track(1, "halted") + _track(2, "active", "tentative") + _det(0) + fits
    for ev in _events(young, {"cost_resumes": 5000}):
        assert "occurs(hides_behind(1,2))" not in ev
    # a confirmed track in front is another object: it can hide track 1 (free for a missing one)
    # (said as hides_behind on request; by default a late hiding is may_hide_behind)
    old = _track(1, "halted") + _track(2, "active") + _det(0) + fits
    late = {"cost_resumes": 5000, "late_maybe": 0}
    assert any("occurs(hides_behind(1,2))" in ev for ev in _events(old, late))


def test_a_track_cut_by_the_border_leaves_rather_than_starts_hiding():
    # track 1 is cut by the border and a track in front covers it (as 3D depth can say of a
    # truncated car): it leaves the view, it does not start hiding
    facts = (
        _track(1, "active", "at_border", "cut")
        + _track(2, "active")
        + _det(0)
        + ("cand(2,d(0),900). covers(d(0),1).")
    )
    for ev in _events(facts):
        assert "occurs(leaves_fov(1))" in ev
        assert not any(a.startswith("occurs(hides_behind(1,") for a in ev)
    # away from the border the same track hides; so does one whose top only is cut
    inside = facts.replace("cut(1).", "")
    assert all("occurs(hides_behind(1,2))" in ev for ev in _events(inside))
    assert all(
        "occurs(hides_behind(1,2))" in ev for ev in _events(inside.replace("at_border(1).", ""))
    )


def test_depth_from_a_3d_detector_is_carried_into_the_track_table():
    loc = np.array([[1.0, 1.5, 12.5], [0.0, 1.5, -1000.0]])
    dets = Detections(
        np.array([[0, 0, 10, 10], [20, 0, 30, 10]], dtype=float), data={"location": loc}
    )
    assert dets.depth[0] == 12.5 and np.isnan(dets.depth[1])  # KITTI's placeholder: unknown
    assert np.isnan(Detections(np.array([[0, 0, 10, 10]], dtype=float)).depth).all()
    own = Detections(np.array([[0, 0, 10, 10]], dtype=float), data={"depth": [7.0]})
    assert own.depth.tolist() == [7.0]
    t = Tracker(TrackerConfig(fps=10, image_size=SIZE))
    t.update(frame([100, 100, 200, 200], depth=[20.0]), frame=0)
    assert t.tracks.depth.tolist() == [20.0]
    t.update(frame([102, 100, 202, 200], depth=[19.0]), frame=1)
    assert t.tracks.depth.tolist() == [19.0]  # the depth of the last match


def test_pair_front_with_the_relations_margin_is_the_lower_bottom_y_relation():
    # without depths and cut boxes, front/3 is "bottom_lower" of the y relation pair_relations
    # gives (the same tolerance; boxes taller than twice it, so no degenerate meets), and the
    # tracker's order (no margin) never says the reverse
    from sensemaking.reasoning.relations import IA_RELATIONS, RelationConfig, pair_relations

    lower = {"after", "met_by", "overlapped_by", "contains", "started_by"}
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 300, (60, 2))
    boxes = np.concatenate([xy, xy + rng.uniform(20, 80, (60, 2))], axis=1)
    pairs, codes = pair_relations(boxes, RelationConfig(near=10.0))
    front = pair_front(boxes, pairs, config=RelationConfig())
    assert len(pairs) > 100
    assert [f == 1 for f in front.tolist()] == [
        IA_RELATIONS[c[1]] in lower for c in codes.tolist()
    ]
    plain = in_front(boxes)
    for (i, j), f in zip(pairs.tolist(), front.tolist(), strict=True):
        if f == 1:
            assert plain[i, j]
        elif f == -1:
            assert plain[j, i]


@pytest.mark.slow
def test_kitti_cars_cut_by_the_border_are_not_hidden(shared_data):
    # KITTI 0005 (RRC car): before the cut rule two parked cars cut off at the border, leaving
    # the view, were said to hide behind cars farther away (implausible per the labels)
    from sensemaking.benchmark.datasets import iter_benchmarks
    from sensemaking.benchmark.runner import ours_config
    from sensemaking.evaluation.explanations import evaluate_explanations, load_ground_truth

    bench = next(iter(iter_benchmarks(shared_data, ["kitti-rrc-car"])))
    seq = next(s for s in bench.sequences if s.name == "0005")
    size = (int(seq.info.width), int(seq.info.height))
    tracker = Tracker(ours_config("kitti", fps=float(seq.info.fps), image_size=size))
    frames = dict(seq.detections.frames())
    outputs, events = [], []
    for f in seq.frame_numbers:
        result = tracker.update(frames.get(f, Detections.empty()), frame=f)
        outputs.append(result.visible)
        events += result.events
    gt = load_ground_truth(
        seq.gt_path,
        "kitti",
        image_size=size,
        fps=float(seq.info.fps),
        classes=("car",),
        n_frames=int(seq.info.length),
    )
    verdicts = evaluate_explanations(gt, Detections.concatenate(outputs), events).events
    hides = [v for v in verdicts if v.event.name == "hides_behind"]
    assert hides  # real occlusions are still explained as hiding
    assert not [v for v in hides if v.verdict == "implausible" and v.border]
    assert sum(v.event.name == "leaves_fov" and v.verdict == "plausible" for v in verdicts) > 10

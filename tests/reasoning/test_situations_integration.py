"""The monitor on shared data: synthetic scenes, the tracker's output, KITTI ground truth."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SHARED_DATA
from test_scene_helpers import Obj, build_results

from sensemaking.reasoning.online import SituationMonitor
from sensemaking.reasoning.situations import SituationConfig
from sensemaking.results import TrackState

KITTI = SHARED_DATA / "kitti"


def _oracle_results(sc, hide_cover: float = 0.6):
    gt = sc.ground_truth
    objs = []
    for i in np.unique(gt.tracker_id):
        m = gt.tracker_id == i
        objs.append(
            Obj(
                int(i),
                int(gt.class_id[m][0]),
                {int(f): b for f, b in zip(gt.frame[m], gt.xyxy[m], strict=False)},
            )
        )
    return build_results(objs, sc.n_frames, size=(sc.width, sc.height), hide_cover=hide_cover)


def test_demo_scene_cyclist_behind_turning_car_warns_while_hidden():
    """Figure 1 scene of sensemaking.synthetic with the cyclist reported hidden: HIDDEN_ENTITY
    at the hiding frame, reappearance anticipated within a frame of the truth."""
    synthetic = pytest.importorskip("sensemaking.synthetic")
    sc = next(
        s for s in synthetic.occlusion_suite(0) if s.name == "car_turns_right_hiding_cyclist"
    )
    results = _oracle_results(sc)
    lead = SituationConfig(constants={"he_lead_ms": 5000})  # warned of at the hiding frame
    mon = SituationMonitor(lead, fps=sc.fps, image_size=(sc.width, sc.height))
    (w,) = [w for w in mon.run(results) if w.situation == "HIDDEN_ENTITY"]
    cyclist = w.objects[0]
    hidden = [r.frame for r in results if r.state_of(cyclist) == TrackState.HIDDEN]
    assert w.frame == hidden[0] and w.details["classes"] == ["cyclist", "car"]
    back = next(
        r.frame
        for r in results
        if r.frame > hidden[-1] and r.state_of(cyclist) == TrackState.VISIBLE
    )
    assert abs(w.details["anticipation"]["reappear_frame"] - back) <= 1


@pytest.mark.integration
@pytest.mark.slow
def test_monitor_on_the_trackers_output():
    """Tracker + monitor over the synthetic occlusion suite: every HIDDEN_ENTITY warning names a
    track the tracker reports hidden at that frame, behind the named occluder."""
    synthetic = pytest.importorskip("sensemaking.synthetic")
    tracker_mod = pytest.importorskip("sensemaking.tracker")
    n_hidden = 0
    for sc in synthetic.occlusion_suite(0):
        tracker = tracker_mod.Tracker(
            tracker_mod.TrackerConfig(fps=sc.fps, image_size=(sc.width, sc.height))
        )
        mon = SituationMonitor(fps=sc.fps, image_size=(sc.width, sc.height))
        for f, dets in sc.frames():
            r = tracker.update(dets, frame=f)
            for w in mon.update(r):
                if w.situation == "HIDDEN_ENTITY":
                    n_hidden += 1
                    t, o = w.objects
                    i = int(np.flatnonzero(r.tracks.tracker_id == t)[0])
                    assert (
                        r.tracks.data["state"][i] == TrackState.HIDDEN
                        and r.tracks.data["occluder"][i] == o
                    )
    assert n_hidden >= 1


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.skipif(
    not (KITTI / "detections" / "rrc" / "car" / "0001.txt").exists(),
    reason="needs ../shared/data/kitti with RRC detections",
)
def test_situations_on_the_trackers_kitti_output():
    """KITTI 0002 tracked from RRC detections (cars overtaking, hidden behind others,
    ahead, braking): the four situations of a driving camera occur, each warning is active at its
    frame, and a HIDDEN_ENTITY names a track hidden then behind the named occluder."""
    from sensemaking.detections import Detections
    from sensemaking.io.kitti import read_kitti_detections
    from sensemaking.tracker import Tracker, TrackerConfig

    size = (1242, 375)
    seen: set[str] = set()
    for seq in ("0002",):
        by_frame = dict(
            read_kitti_detections(KITTI / "detections" / "rrc" / "car" / f"{seq}.txt").frames()
        )
        tracker = Tracker(TrackerConfig.for_dataset("kitti", fps=10.0, image_size=size))
        mon = SituationMonitor(SituationConfig(), fps=10.0, image_size=size)
        for f in range(max(by_frame) + 1):
            r = tracker.update(by_frame.get(f, Detections.empty()), frame=f)
            new = mon.update(r)
            active = [w.to_json() for w in mon.active]
            assert all(w.to_json() in active for w in new if w.objects)  # not the notes
            for w in new:
                if w.situation == "HIDDEN_ENTITY":
                    i = int(np.flatnonzero(r.tracks.tracker_id == w.objects[0])[0])
                    assert r.tracks.data["state"][i] == TrackState.HIDDEN
                    assert r.tracks.data["occluder"][i] == w.objects[1]
            seen |= {w["situation"] for w in active}
    assert {"OVERTAKING", "HIDDEN_ENTITY", "REDUCED_VISIBILITY", "SUDDEN_STOP"} <= seen

"""The explanation evaluator on small synthetic ground truth (sensemaking.synthetic) and tiny
hand-made KITTI-like labels: true explanations are plausible, false ones implausible."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sensemaking.classes import CLASS_IDS
from sensemaking.cli import main
from sensemaking.detections import Detections
from sensemaking.evaluation.explanations import (
    IMPLAUSIBLE,
    PLAUSIBLE,
    ExplanationResult,
    GroundTruth,
    WarningVerdict,
    confidence_text,
    evaluate_explanations,
    explanation_table,
    late_start_events,
    match_tracks,
)
from sensemaking.records import event_from_record, event_record
from sensemaking.results import Event
from sensemaking.synthetic import crossing_scene, occlusion_suite
from sensemaking.tracker import Tracker, TrackerConfig


def _truth(scene, boxes: Detections | None = None, kind: str = "mot") -> GroundTruth:
    gt = scene.ground_truth if boxes is None else boxes
    return GroundTruth(
        gt,
        np.ones(len(gt), dtype=bool),
        kind,
        (scene.width, scene.height),
        scene.fps,
        0,
        scene.n_frames,
    )


def _perfect_tracks(scene, gt: Detections | None = None) -> Detections:
    """A perfect tracker: the ground-truth box of every object on the frames it was detected,
    with the object id as track id."""
    gt = scene.ground_truth if gt is None else gt
    seen = set(
        zip(scene.detections.data["gt_id"].tolist(), scene.detections.frame.tolist(), strict=True)
    )
    keep = np.array(
        [(t, f) in seen for t, f in zip(gt.tracker_id.tolist(), gt.frame.tolist(), strict=True)]
    )
    return Detections(xyxy=gt.xyxy[keep], tracker_id=gt.tracker_id[keep], frame=gt.frame[keep])


@pytest.fixture(scope="module")
def crossing():
    """Object 1 (far, bottom ~296) passes behind object 2 (near, bottom ~311); object 1 is not
    detected on frames 13-18."""
    scene = crossing_scene(0, gap=6)
    det = scene.detections
    missed = sorted(set(range(scene.n_frames)) - set(det.frame[det.data["gt_id"] == 1].tolist()))
    assert missed == list(range(13, 19))  # the scene the tests below are written for
    return scene


HIDE = Event(13, "hides_behind", (1, 2))
UNHIDE = Event(19, "unhides_from_behind", (1, 2))


def _one(result: ExplanationResult, event: Event):
    return next(v for v in result.events if v.event == event)


def test_true_occlusion_is_plausible_and_identity_kept(crossing):
    res = evaluate_explanations(_truth(crossing), _perfect_tracks(crossing), [HIDE, UNHIDE])
    hide = _one(res, HIDE)
    assert (hide.verdict, hide.reason, hide.gt, hide.identity) == (
        "plausible",
        "occluded_in_front",
        (1, 2),
        "kept",
    )
    assert _one(res, UNHIDE).verdict == "plausible"
    assert res.recall["hides_behind"] == (1, 1)


def test_occluder_farther_away_is_implausible(crossing):
    """The same scene with object 2 lifted 40 px: its bottom is now above object 1's, so it is
    farther away and cannot hide it, though the boxes still overlap."""
    gt = crossing.ground_truth
    lifted = gt.xyxy.copy()
    lifted[gt.tracker_id == 2] -= [0, 40, 0, 40]
    gt = gt.with_(xyxy=lifted)
    res = evaluate_explanations(_truth(crossing, gt), _perfect_tracks(crossing, gt), [HIDE])
    assert (_one(res, HIDE).verdict, _one(res, HIDE).reason) == ("implausible", "occluder_behind")


def test_hidden_behind_itself_is_implausible(crossing):
    """Track 3 takes over object 1 (an identity switch): 'track 1 hides behind track 3' names
    the same object twice."""
    tracks = _perfect_tracks(crossing)
    gt = crossing.ground_truth
    late = (gt.tracker_id == 1) & (gt.frame >= 13)
    late = Detections(
        xyxy=gt.xyxy[late], tracker_id=np.full(int(late.sum()), 3), frame=gt.frame[late]
    )
    tracks = Detections.concatenate(
        [tracks[~((tracks.tracker_id == 1) & (tracks.frame >= 13))], late]
    )
    ev = Event(13, "hides_behind", (1, 3))
    res = evaluate_explanations(_truth(crossing), tracks, [ev])
    assert (_one(res, ev).verdict, _one(res, ev).reason, _one(res, ev).gt) == (
        "implausible",
        "self",
        (1, 1),
    )
    assert res.summary()["events"]["hides_behind"]["self"] == 1


def test_visible_object_said_hidden_is_implausible(crossing):
    ev = Event(13, "hides_behind", (2, 1))  # object 2 is in front, fully visible
    res = evaluate_explanations(_truth(crossing), _perfect_tracks(crossing), [ev])
    assert (_one(res, ev).verdict, _one(res, ev).reason) == ("implausible", "not_occluded")


def test_undecidable_without_visibility_or_without_a_match(crossing):
    boxes_only = _truth(crossing, kind="boxes")
    v = _one(evaluate_explanations(boxes_only, _perfect_tracks(crossing), [HIDE]), HIDE)
    assert (v.verdict, v.reason) == ("undecidable", "occlusion_unknown")
    ghost = Detections(
        xyxy=np.array([[10.0, 10, 40, 60]]), tracker_id=np.array([7]), frame=np.array([12])
    )
    tracks = Detections.concatenate([_perfect_tracks(crossing), ghost])
    ev = Event(13, "hides_behind", (7, 2))
    v = _one(evaluate_explanations(_truth(crossing), tracks, [ev]), ev)
    assert (v.verdict, v.reason, v.gt) == ("undecidable", "unmatched", (None, 2))
    s = ExplanationResult("x", [v]).summary()["events"]["hides_behind"]
    assert (s["undecidable"], s["precision"]) == (1, None)


def test_events_of_a_users_encoding_are_no_crash(crossing):
    """A user's encoding may abduce events without arguments or with constants: recall ignores
    them, and a constant where a track id belongs names no track (unmatched)."""
    truth, tracks = _truth(crossing), _perfect_tracks(crossing)
    base = evaluate_explanations(truth, tracks, [HIDE, UNHIDE])
    foggy, by_wall = Event(3, "foggy", ()), Event(13, "hides_behind", ("wall", 2))
    res = evaluate_explanations(truth, tracks, [HIDE, UNHIDE, foggy, by_wall])
    assert res.recall == base.recall
    v = _one(res, by_wall)
    assert (v.verdict, v.reason, v.gt) == ("undecidable", "unmatched", (None, 2))


def test_enter_leave_start_at_the_border():
    scene = next(s for s in occlusion_suite(0) if s.name == "leave_and_enter_at_border")
    gt = scene.ground_truth
    frames = {i: gt.frame[gt.tracker_id == i] for i in (1, 2, 3)}
    # 1 leaves at the right border, 2 enters there, 3 (a car) enters at the left border
    truth, tracks = _truth(scene), _perfect_tracks(scene)
    leave = Event(int(frames[1].max()) + 1, "leaves_fov", (1,))
    enter = Event(int(frames[2].min()), "enters_fov", (2,))
    start = Event(int(frames[2].min()), "starts", (2,))
    mid = int(frames[1].min()) + 3  # object 1 well inside the image
    false_leave = Event(mid, "leaves_fov", (1,))
    lost = Event(int(frames[1].max()) + 1, "ends", (1,))
    res = evaluate_explanations(truth, tracks, [leave, enter, start, false_leave, lost])
    got = {(v.event.name, v.event.frame): (v.verdict, v.reason) for v in res.events}
    assert got[("leaves_fov", leave.frame)] == ("plausible", "crossed_border")
    assert got[("enters_fov", enter.frame)] == ("plausible", "crossed_border")
    assert got[("starts", start.frame)] == ("implausible", "entered_at_border")
    assert got[("leaves_fov", mid)] == ("implausible", "inside_image")
    assert got[("ends", lost.frame)] == ("implausible", "left_view")
    # recall: objects 2 and 3 enter at a border; only 2 has an enters_fov event
    assert res.recall["enters_fov"] == (1, 2)


def test_missing_detections_and_reappears(crossing):
    miss = Event(13, "missing_detections", (1,))
    back = Event(19, "reappears", (1,))
    res = evaluate_explanations(_truth(crossing), _perfect_tracks(crossing), [miss, back])
    assert (_one(res, miss).verdict, _one(res, miss).reason) == ("plausible", "in_view")
    assert (_one(res, back).verdict, _one(res, back).reason) == ("plausible", "same_object")
    # the track comes back on object 2's box: another object
    tracks = _perfect_tracks(crossing)
    gt = crossing.ground_truth
    swapped = tracks.xyxy.copy()
    swapped[(tracks.tracker_id == 1) & (tracks.frame == 19)] = gt.xyxy[
        (gt.tracker_id == 2) & (gt.frame == 19)
    ]
    keep = ~((tracks.tracker_id == 2) & (tracks.frame == 19))
    res = evaluate_explanations(_truth(crossing), tracks.with_(xyxy=swapped)[keep], [back])
    assert (_one(res, back).verdict, _one(res, back).reason) == ("implausible", "identity_switch")


@pytest.mark.parametrize("name", ["reenters_fov", "returns"])
def test_a_revived_track_is_judged_as_a_reappearance(crossing, name):
    back = Event(19, name, (1,))
    res = evaluate_explanations(_truth(crossing), _perfect_tracks(crossing), [back])
    assert (_one(res, back).verdict, _one(res, back).reason) == ("plausible", "same_object")
    assert res.summary()["events"][name]["total"] == 1


def _hidden_entity(frame: int, reappear: int, x: float, y: float) -> dict:
    return {
        "frame": frame,
        "situation": "HIDDEN_ENTITY",
        "objects": [1, 2],
        "message": "",
        "details": {
            "reappear_frame": reappear,
            "anticipation": {"reappear_frame": reappear, "position": [x, y]},
        },
    }


def test_hidden_entity_reappearance_error(crossing):
    """Object 1 is seen again (visibility >= 0.5) from frame 20, bottom centre (678.3, 295.5)."""
    gt = crossing.ground_truth
    row = (gt.tracker_id == 1) & (gt.frame == 20)
    x1, _, x2, y2 = gt.xyxy[row][0]
    cx = (x1 + x2) / 2
    on = _hidden_entity(14, 19, cx + 30, y2)
    off = _hidden_entity(14, 19, cx + 80, y2)
    late = _hidden_entity(14, 25, cx, y2)
    note = {
        "frame": 0,
        "situation": "BLOCKED_LANE",
        "objects": [],
        "message": "not checked",
        "details": {},
    }
    res = evaluate_explanations(
        _truth(crossing), _perfect_tracks(crossing), [], [on, off, late, note]
    )
    assert len(res.warnings) == 3  # the note is not a warning
    a, b, c = res.warnings
    assert (a.verdict, a.reason, a.frame_error, a.px_error, a.lead_frames) == (
        "plausible",
        "on_target",
        1,
        30.0,
        6,
    )
    assert (b.verdict, b.reason) == ("implausible", "elsewhere")
    assert (c.verdict, c.reason, c.frame_error) == ("implausible", "late_or_early", -5)
    s = res.summary()["warnings"]["HIDDEN_ENTITY"]
    assert (s["reappeared"], s["on_target"], s["on_target_of_reappeared"]) == (
        3,
        1,
        pytest.approx(1 / 3),
    )


def _kitti_labels(rows: list[tuple[int, int, list[float], float, float]]) -> Detections:
    """(frame, id, xyxy, X, Z) rows -> KITTI-like car labels (occluded 0, not truncated)."""
    n = len(rows)
    loc = np.array([[r[3], 1.5, r[4]] for r in rows])
    return Detections(
        xyxy=np.array([r[2] for r in rows], dtype=np.float64),
        tracker_id=np.array([r[1] for r in rows]),
        frame=np.array([r[0] for r in rows]),
        class_id=np.full(n, CLASS_IDS["car"]),
        data={"occluded": np.zeros(n, np.int64), "truncated": np.zeros(n), "location": loc},
    )


def test_sudden_stop_against_3d_time_to_contact():
    box = [500.0, 150, 700, 250]
    side = [900.0, 150, 1100, 250]
    rows = []
    for f in range(6):  # car 1 ahead in the lane closing at 10 m/s from 20 m; car 2 5 m aside
        rows.append((f, 1, box, 0.5, 20.0 - f))
        rows.append((f, 2, side, 5.0, 20.0 - f))
        rows.append((f, 3, [300.0, 150, 480, 250], -1.0, 20.0))  # 3: in the lane, not closing
    labels = _kitti_labels(rows)
    gt = GroundTruth.from_kitti(labels, image_size=(1242, 375), fps=10.0, classes=("car",))
    tracks = labels.with_(tracker_id=labels.tracker_id + 10)
    warn = [
        {"frame": 5, "situation": "SUDDEN_STOP", "objects": [t], "details": {}}
        for t in (11, 12, 13)
    ]
    res = evaluate_explanations(gt, tracks, [], warn)
    a, b, c = res.warnings
    assert (a.verdict, a.reason, a.ttc_s) == (
        "plausible",
        "closing_in_lane",
        1.5,
    )  # 15 m at 10 m/s
    assert (b.verdict, b.reason, b.lateral_m) == ("implausible", "to_the_side", 5.0)
    assert (c.verdict, c.reason, c.ttc_s) == ("implausible", "not_closing", math.inf)
    assert "ttc_s" not in c.to_json()  # not closing: no number in the JSON


def test_sudden_stop_time_to_contact_is_to_the_near_face_not_the_centre():
    """A 4 m long car seen from behind (rotation_y -pi/2), its centre 20 m ahead at frame 5,
    closing at 5 m/s: contact comes when its rear, 18 m ahead, is reached: 3.6 s, not 4.0 s."""
    rows = [(f, 1, [500.0, 150, 700, 250], 0.5, 22.5 - 0.5 * f) for f in range(6)]
    labels = _kitti_labels(rows)
    n = len(rows)
    labels = labels.with_(
        data={
            **labels.data,
            "dimensions": np.tile([1.5, 1.8, 4.0], (n, 1)),
            "rotation_y": np.full(n, -math.pi / 2),
        }
    )
    gt = GroundTruth.from_kitti(labels, image_size=(1242, 375), fps=10.0, classes=("car",))
    warn = [{"frame": 5, "situation": "SUDDEN_STOP", "objects": [11], "details": {}}]
    (v,) = evaluate_explanations(
        gt, labels.with_(tracker_id=labels.tracker_id + 10), [], warn
    ).warnings
    assert v.ttc_s == pytest.approx(3.6)  # (20 m centre - 2 m half length) / 5 m/s
    # side on (rotation_y 0): the near face is half the width away
    labels2 = labels.with_(data={**labels.data, "rotation_y": np.zeros(n)})
    gt2 = GroundTruth.from_kitti(labels2, image_size=(1242, 375), fps=10.0, classes=("car",))
    (v2,) = evaluate_explanations(
        gt2, labels2.with_(tracker_id=labels2.tracker_id + 10), [], warn
    ).warnings
    assert v2.ttc_s == pytest.approx((20.0 - 0.9) / 5.0, abs=0.01)


def test_kitti_depth_decides_the_occluder_not_the_box_bottom():
    """The 'occluder' has the lower box bottom, but its 3D position is 6 m behind the hidden car
    (a near car cut by the border): implausible. With the depths swapped: plausible."""
    hidden = [1000.0, 200, 1242, 374]
    occluder = [850.0, 180, 1200, 375]

    def labels(z_hidden: float, z_occluder: float) -> Detections:
        rows = [
            (0, 1, hidden, 3.8, z_hidden),
            (0, 2, occluder, 3.9, z_occluder),
            (1, 1, hidden, 3.8, z_hidden),
            (1, 2, occluder, 3.9, z_occluder),
        ]
        lab = _kitti_labels(rows)
        occl = np.array([0, 0, 1, 0])
        return lab.with_(data={**lab.data, "occluded": occl})

    ev = Event(1, "hides_behind", (1, 2))
    for (zh, zo), expected in (
        ((2.0, 8.0), ("implausible", "occluder_behind")),
        ((8.0, 2.0), ("plausible", "occluded_in_front")),
    ):
        lab = labels(zh, zo)
        gt = GroundTruth.from_kitti(lab, image_size=(1242, 375), classes=("car",))
        tracks = lab[~((lab.frame == 1) & (lab.tracker_id == 1))]
        v = _one(evaluate_explanations(gt, tracks, [ev]), ev)
        assert (v.verdict, v.reason) == expected
        assert v.border  # the hidden car's box touches the right border


def test_match_tracks_is_the_hungarian_assignment():
    """Track 8 overlaps both objects; the assignment that maximises total IoU gives it object 2
    and object 1 to track 9, though track 8 fits object 1 best."""
    gt = Detections(
        xyxy=np.array([[0.0, 0, 10, 10], [4.0, 0, 14, 10]]),
        tracker_id=np.array([1, 2]),
        frame=np.array([1, 1]),
    )
    tracks = Detections(
        xyxy=np.array([[1.0, 0, 11, 10], [-1.0, 0, 9, 10]]),
        tracker_id=np.array([8, 9]),
        frame=np.array([1, 1]),
    )
    assert match_tracks(gt, tracks) == {(8, 1): 2, (9, 1): 1}
    far = tracks.with_(xyxy=tracks.xyxy + [20, 0, 20, 0])
    assert match_tracks(gt, far) == {}


def test_late_start_events_counts_starts_before_the_first_output():
    tracks = Detections(
        xyxy=np.tile([0.0, 0, 5, 5], (3, 1)),
        tracker_id=np.array([1, 1, 2]),
        frame=np.array([3, 4, 2]),
    )
    events = [
        Event(1, "starts", (1,)),
        Event(2, "enters_fov", (2,)),
        Event(5, "starts", (4,)),
        Event(2, "leaves_fov", (1,)),
    ]
    assert late_start_events(tracks, events) == (2, 3)  # track 1 (output from 3) and 4 (never)


def test_real_tracker_on_a_crossing_explains_it_plausibly(crossing):
    """Our tracker on the synthetic crossing: every hides_behind it abduces is true."""
    tracker = Tracker(
        TrackerConfig.for_dataset("kitti", image_size=(crossing.width, crossing.height))
    )
    out, events = [], []
    for f, dets in crossing.frames():
        r = tracker.update(dets, frame=f)
        out.append(r.visible)
        events += r.events
    res = evaluate_explanations(_truth(crossing), Detections.concatenate(out), events)
    hides = [v for v in res.events if v.event.name == "hides_behind"]
    assert hides and all(v.verdict == "plausible" for v in hides)


def test_table_has_a_row_per_judged_kind(crossing):
    res = evaluate_explanations(_truth(crossing), _perfect_tracks(crossing), [HIDE, UNHIDE])
    table = explanation_table({"synthetic": [res]})
    rows = [line.split("|")[2].strip() for line in table.splitlines()[2:]]
    assert rows == [
        "hides_behind",
        "unhides_from_behind",
        "starts/enters_fov before the track's first output frame",
    ]
    assert "| synthetic | hides_behind | 1 | 1 | 0 | 0 | 100.0 | 100.0 | 100.0 of 1 |" in table


# -- the CLI ---------------------------------------------------------------------------------
@pytest.fixture
def mot_run(tmp_path, crossing):
    """The crossing as a MOTChallenge sequence (frames from 1): gt, perfect results, events."""
    seq = tmp_path / "gt" / "CROSS"
    (seq / "gt").mkdir(parents=True)
    gt = crossing.ground_truth
    with open(seq / "gt" / "gt.txt", "w") as fh:
        for f, i, (x1, y1, x2, y2), v in zip(
            gt.frame, gt.tracker_id, gt.xyxy, gt.data["visibility"], strict=True
        ):
            fh.write(f"{f + 1},{i},{x1:.2f},{y1:.2f},{x2 - x1:.2f},{y2 - y1:.2f},1,1,{v:.3f}\n")
    (seq / "seqinfo.ini").write_text(
        f"[Sequence]\nname=CROSS\nseqLength={crossing.n_frames}\n"
        f"imWidth={crossing.width}\nimHeight={crossing.height}\nframeRate=10\n"
    )
    tr = _perfect_tracks(crossing)
    res = tmp_path / "CROSS.txt"
    with open(res, "w") as fh:
        for f, i, (x1, y1, x2, y2) in zip(tr.frame, tr.tracker_id, tr.xyxy, strict=True):
            fh.write(f"{f + 1},{i},{x1:.2f},{y1:.2f},{x2 - x1:.2f},{y2 - y1:.2f},1,-1,-1,-1\n")
    events = tmp_path / "CROSS.events.jsonl"
    events.write_text(
        "".join(
            json.dumps(event_record(Event(e.frame + 1, e.name, e.args))) + "\n"
            for e in (HIDE, UNHIDE)
        )
    )
    return tmp_path, res, events


def test_cli_explanations_table_and_json(mot_run, capsys):
    tmp, res, events = mot_run
    out = tmp / "out" / "verdicts.json"
    rc = main(
        [
            "evaluate",
            "--explanations",
            "--gt",
            str(tmp / "gt"),
            "--results",
            str(res),
            "--events",
            str(events),
            "--json",
            str(out),
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "| mot17 | hides_behind | 1 | 1 | 0 | 0 |" in text
    doc = json.loads(out.read_text())
    [verdict] = [v for v in doc["sequences"]["CROSS"]["events"] if v["event"] == "hides_behind"]
    assert (verdict["verdict"], verdict["gt"], verdict["identity"]) == (
        "plausible",
        [1, 2],
        "kept",
    )


def test_cli_explanations_bad_input_is_one_line(mot_run, capsys):
    tmp, res, events = mot_run
    events.write_text(
        '{"frame": 14, "event": "hides_behind", "args": [1, 2]}\n{"frame": 20, "event"\n'
    )
    before = res.read_text()
    rc = main(
        [
            "evaluate",
            "--explanations",
            "--gt",
            str(tmp / "gt"),
            "--results",
            str(res),
            "--events",
            str(events),
            "--json",
            str(tmp / "v.json"),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and f"{events}:2: not JSON" in err and len(err.strip().splitlines()) == 1
    assert not (tmp / "v.json").exists() and res.read_text() == before
    events.write_text('{"frame": 14, "event": "hides_behind", "args": [1]}\n')
    assert (
        main(
            [
                "evaluate",
                "--explanations",
                "--gt",
                str(tmp / "gt"),
                "--results",
                str(res),
                "--events",
                str(events),
            ]
        )
        == 2
    )
    assert f"{events}:1: hides_behind takes 2 argument(s)" in capsys.readouterr().err


def test_cli_events_need_explanations_and_explanations_need_events(mot_run, capsys):
    tmp, res, events = mot_run
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--gt", str(tmp / "gt"), "--results", str(res), "--events", str(events)])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--explanations", "--gt", str(tmp / "gt"), "--results", str(res)])
    assert exc.value.code == 2
    assert "--explanations needs --events" in capsys.readouterr().err


def test_cli_explanations_folders_of_sequences(mot_run, capsys):
    """--results, --events and --warnings as folders of <seq>.txt / <seq>.events.jsonl /
    <seq>.warnings.jsonl; a sequence without an event log is an error naming the folder."""
    tmp, res, events = mot_run
    runs = tmp / "runs"
    runs.mkdir()
    res.rename(runs / "CROSS.txt")
    events.rename(runs / "CROSS.events.jsonl")
    note = {"frame": 1, "situation": "BLOCKED_LANE", "objects": [], "message": "", "details": {}}
    (runs / "CROSS.warnings.jsonl").write_text(json.dumps(note) + "\n")
    args = ["evaluate", "--explanations", "--gt", str(tmp / "gt"), "--results", str(runs)]
    assert main(args + ["--events", str(runs), "--warnings", str(runs)]) == 0
    assert "| mot17 | unhides_from_behind | 1 | 1 | 0 | 0 |" in capsys.readouterr().out
    (runs / "CROSS.events.jsonl").unlink()
    assert main(args + ["--events", str(runs)]) == 2
    assert "no CROSS.jsonl or CROSS.events.jsonl" in capsys.readouterr().err


def test_overtaking_needs_a_flip_of_the_3d_depth_order():
    """Car 1 drives past car 2 in the next lane (Z from 12 to 18 m, car 2 stays at 15 m, 3 m
    apart): plausible. Car 3 parked behind car 2 in the same lane at a constant 5 m: no flip."""
    rows = []
    for f in range(11):
        rows.append((f, 1, [400.0 + f, 150, 500, 250], -1.5, 12.0 + 0.6 * f))
        rows.append((f, 2, [600.0, 150, 700, 250], 1.5, 15.0))
        rows.append((f, 3, [800.0, 150, 900, 250], 1.8, 20.0))
    labels = _kitti_labels(rows)
    gt = GroundTruth.from_kitti(labels, image_size=(1242, 375), fps=10.0, classes=("car",))
    tracks = labels.with_(tracker_id=labels.tracker_id + 10)
    warn = [
        {"frame": 10, "situation": "OVERTAKING", "objects": [a, b], "details": d}
        for a, b, d in ((11, 12, {"nearer_until": 2}), (13, 12, {}), (11, 11, {}))
    ]
    a, b, c = evaluate_explanations(gt, tracks, [], warn).warnings
    assert (a.verdict, a.reason, a.lateral_m) == ("plausible", "passed_in_depth", 3.0)
    assert (b.verdict, b.reason) == ("implausible", "no_depth_flip")
    assert (c.verdict, c.reason) == ("implausible", "self")


def test_occlusion_recall_says_what_the_tracker_said_instead(crossing):
    """The one recall occasion of the crossing (track 1 lost at frame 13 while object 1 is
    occluded inside the image) counted by what the tracker said there."""
    truth, tracks = _truth(crossing), _perfect_tracks(crossing)
    res = evaluate_explanations(truth, tracks, [HIDE, UNHIDE])
    assert res.occlusions_said == {"hides_behind": 1}
    missing = Event(13, "missing_detections", (1,))
    res = evaluate_explanations(truth, tracks, [missing, Event(13, "hides_behind", (2, 1))])
    assert res.recall["hides_behind"] == (0, 1)
    assert res.occlusions_said == {"missing_detections": 1}
    combined = ExplanationResult.combine([res, evaluate_explanations(truth, tracks, [])])
    said = combined.summary()["events"]["hides_behind"]["occlusions_said"]
    assert said == {
        "hides_behind": 0,
        "leaves_fov": 0,
        "missing_detections": 1,
        "ends": 0,
        "nothing": 1,
    }
    table = explanation_table({"b": combined})
    assert "occluded when lost, said instead: missing_detections 1, nothing 1" in table
    # without visibility in the ground truth there is no occasion, and nothing is counted
    assert (
        evaluate_explanations(_truth(crossing, kind="boxes"), tracks, [missing]).occlusions_said
        == {}
    )


def test_read_events_and_warnings_name_the_bad_line(tmp_path):
    from sensemaking.errors import InputError
    from sensemaking.evaluation.explanations import judged_warnings, read_events, read_warnings

    ev = tmp_path / "e.jsonl"
    ev.write_text('{"frame": 3, "event": "hides_behind", "args": [1, 2]}\n\n[1]\n')
    with pytest.raises(InputError, match=r"e\.jsonl:3"):
        read_events(ev)
    ev.write_text('{"frame": 3, "event": "hides_behind", "args": [1, 2]}\n')
    assert read_events(ev) == [Event(3, "hides_behind", (1, 2))]
    w = tmp_path / "w.jsonl"
    w.write_text(
        '{"frame": 1, "situation": "BLOCKED_LANE", "objects": [], "details": {}}\n'
        '{"frame": 2, "situation": "HIDDEN_ENTITY", "objects": [4], "details": {}}\n'
    )
    records = read_warnings(w)
    assert [r["frame"] for r in judged_warnings(records)] == [2]
    w.write_text('{"frame": "2", "situation": "HIDDEN_ENTITY", "objects": [4]}\n')
    with pytest.raises(InputError, match=r"w\.jsonl:1"):
        read_warnings(w)


# -- confidence: a precision-recall table a user can threshold (issue 22) --------------------
def test_confidence_table_keeps_the_events_at_or_above_each_threshold(crossing):
    """A true hiding at confidence 0.9 and a false one (behind itself) at 0.55: keeping the
    events of 0.6 and more leaves the true one; recall counts its occasion up to 0.9 only."""
    sure = Event(13, "hides_behind", (1, 2), 0.9)
    wrong = Event(5, "hides_behind", (2, 2), 0.55)
    res = evaluate_explanations(_truth(crossing), _perfect_tracks(crossing), [sure, wrong, UNHIDE])
    row = res.summary()["events"]["hides_behind"]
    by = {r["threshold"]: r for r in row["by_confidence"]}
    assert (by[0.0]["n"], by[0.0]["plausible"], by[0.0]["implausible"]) == (2, 1, 1)
    assert by[0.0]["precision"] == 0.5 and by[0.5]["precision"] == 0.5
    assert (by[0.6]["n"], by[0.6]["precision"]) == (1, 1.0)
    assert by[0.9]["recall"] == row["recall"] == 1.0
    assert (by[1.0]["n"], by[1.0]["precision"], by[1.0]["recall"]) == (0, None, 0.0)
    text = confidence_text({"synthetic": [res]})
    assert "| synthetic | 0.6 | 1 | 1 | 0 | 100.0 | 100.0 |" in text


def test_confidence_round_trips_through_the_event_record():
    e = Event(3, "hides_behind", (1, 2), 0.65)
    rec = event_record(e)
    assert rec["confidence"] == 0.65
    back = event_from_record(json.loads(json.dumps(rec)))
    assert back == e and back.confidence == 0.65
    assert "confidence" not in event_record(Event(3, "ends", (1,)))


# -- the precision-recall curve in the HTML page (issue 22, item 2) -------------------------------
def _svg_points(page: str, kind: str) -> list[tuple[float, float, float]]:
    """(threshold, recall, precision) of the curve's points of ``kind`` in an HTML page."""
    import re
    import xml.etree.ElementTree as ET

    fig = re.search(rf'<figure class="pr" data-kind="{kind}">(<svg.*?</svg>)', page, re.S)
    assert fig is not None
    svg = ET.fromstring(fig.group(1))
    return [
        (
            float(c.get("data-threshold")),
            float(c.get("data-recall")),
            float(c.get("data-precision")),
        )
        for c in svg.iter("circle")
    ]


def test_pr_curve_points_are_the_table_rows_with_precision_and_recall():
    from sensemaking.evaluation.curves import curve_points, pr_curve_svg

    rows = [
        {
            "threshold": 0.0,
            "n": 2,
            "plausible": 1,
            "implausible": 1,
            "precision": 0.5,
            "recall": 1.0,
        },
        {
            "threshold": 0.6,
            "n": 1,
            "plausible": 1,
            "implausible": 0,
            "precision": 1.0,
            "recall": 0.5,
        },
        {
            "threshold": 1.0,
            "n": 0,
            "plausible": 0,
            "implausible": 0,
            "precision": None,
            "recall": 0.0,
        },
    ]
    assert curve_points(rows) == [(0.0, 1.0, 0.5), (0.6, 0.5, 1.0)]
    svg = pr_curve_svg(rows, "a <b>")
    assert svg.count('class="pr-point"') == 2 and "a &lt;b&gt;" in svg
    assert "no threshold" in pr_curve_svg(rows[2:], "none")


def test_cli_html_curve_equals_the_printed_confidence_table(mot_run, capsys):
    """A true hiding at confidence 0.9 and one behind itself at 0.55: every point of the
    page's hides_behind curve is a row of the printed table, and every printed row with a
    precision and a recall is a point."""
    tmp, res, events = mot_run
    events.write_text(
        "".join(
            json.dumps(event_record(Event(e.frame + 1, e.name, e.args, c))) + "\n"
            for e, c in (
                (Event(13, "hides_behind", (1, 2)), 0.9),
                (Event(5, "hides_behind", (2, 2)), 0.55),
                (UNHIDE, None),
            )
        )
    )
    page_path = tmp / "out" / "explanations.html"
    args = ["evaluate", "--explanations", "--gt", str(tmp / "gt"), "--results", str(res)]
    assert main([*args, "--events", str(events), "--html", str(page_path)]) == 0
    printed = {}
    for line in capsys.readouterr().out.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 7 and cells[0] == "mot17" and cells[1][0].isdigit():
            printed[float(cells[1])] = (cells[5], cells[6])
    assert set(printed) == {0.0, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0}
    page = page_path.read_text()
    assert "http" not in page and "<script" not in page  # opens offline
    points = _svg_points(page, "hides_behind")
    assert len(points) >= 2
    assert {t for t, _, _ in points} == {t for t, (p, r) in printed.items() if "-" not in (p, r)}
    for thr, recall, precision in points:
        assert printed[thr] == (f"{100 * precision:.1f}", f"{100 * recall:.1f}")
    with pytest.raises(SystemExit):  # the page is about explanations only
        main(["evaluate", "--gt", str(tmp / "gt"), "--results", str(res), "--html", "x.html"])


# -- warnings with a confidence (HIDDEN_ENTITY, issue 22 item 2) ----------------------------------
def _warned(verdict: str, confidence: float | None) -> WarningVerdict:
    return WarningVerdict(10, "HIDDEN_ENTITY", (1, 2), verdict, "test", confidence=confidence)


def test_warnings_are_kept_at_or_above_each_confidence():
    """Two right warnings (0.9, 0.5) and a wrong one (0.6): at 0.6 precision is 1 of 2 and one
    of the two right warnings is kept; at 1.0 none is kept. Warnings without any confidence
    get no table."""
    res = ExplanationResult(
        "s",
        warnings=[_warned(PLAUSIBLE, 0.9), _warned(PLAUSIBLE, 0.5), _warned(IMPLAUSIBLE, 0.6)],
    )
    row = res.summary()["warnings"]["HIDDEN_ENTITY"]
    by = {r["threshold"]: r for r in row["by_confidence"]}
    assert (by[0.0]["n"], by[0.0]["precision"], by[0.0]["recall"]) == (3, 2 / 3, 1.0)
    assert (by[0.6]["n"], by[0.6]["precision"], by[0.6]["recall"]) == (2, 0.5, 0.5)
    assert (by[0.9]["n"], by[0.9]["precision"], by[0.9]["recall"]) == (1, 1.0, 0.5)
    assert (by[1.0]["n"], by[1.0]["precision"], by[1.0]["recall"]) == (0, None, 0.0)
    text = confidence_text({"bench": [res]})
    assert "| bench | HIDDEN_ENTITY | 0.6 | 2 | 1 | 1 | 50.0 | 50.0 |" in text
    bare = ExplanationResult("s", warnings=[_warned(PLAUSIBLE, None)])
    assert "by_confidence" not in bare.summary()["warnings"]["HIDDEN_ENTITY"]
    assert confidence_text({"bench": [bare]}) == ""


def test_a_warnings_confidence_is_read_from_its_record_and_drawn(mot_run):
    """The judge reads the record's confidence (a number in 0..1, else none), and the HTML page
    draws the warning's curve from the same rows as the table."""
    from sensemaking.evaluation.curves import explanations_html
    from sensemaking.evaluation.explanations import _stated_confidence

    assert _stated_confidence({"confidence": 0.75}) == 0.75
    assert _stated_confidence({"details": {"confidence": 0.25}}) == 0.25
    for bad in (True, "0.5", 1.5, float("nan"), None):
        assert _stated_confidence({"confidence": bad}) is None
    res = ExplanationResult("s", warnings=[_warned(PLAUSIBLE, 0.9), _warned(IMPLAUSIBLE, 0.6)])
    page = explanations_html({"bench": [res]})
    rows = res.summary()["warnings"]["HIDDEN_ENTITY"]["by_confidence"]
    points = [
        (r["threshold"], r["recall"], r["precision"])
        for r in rows
        if r["recall"] is not None and r["precision"] is not None
    ]
    drawn = _svg_points(page, "HIDDEN_ENTITY")
    assert len(drawn) == len(points) == 6
    assert all(d == pytest.approx(p, abs=1e-3) for d, p in zip(drawn, points, strict=True))

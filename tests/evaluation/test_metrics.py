"""Unit tests of sensemaking.evaluation on tiny hand-made sequences with hand-computed values."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.evaluation import (
    ALPHAS,
    COMBINED,
    DatasetRules,
    SequenceMetrics,
    evaluate,
    evaluate_sequence,
    get_rules,
    load_kitti_benchmark,
    load_mot_benchmark,
    read_seqmap,
    rules_for_benchmark,
)

CAR, VAN, PED, DONTCARE = (
    CLASS_IDS["car"],
    CLASS_IDS["van"],
    CLASS_IDS["pedestrian"],
    CLASS_IDS["dontcare"],
)
B = [0.0, 0.0, 10.0, 10.0]
FAR = [100.0, 100.0, 110.0, 110.0]


def dets(boxes, ids, frames, **kw) -> Detections:
    return Detections(
        xyxy=np.asarray(boxes, dtype=float).reshape(-1, 4), tracker_id=ids, frame=frames, **kw
    )


def approx(x):
    return pytest.approx(x, rel=1e-12, abs=1e-12)


# ---------------------------------------------------------------------------------------------
# hand-computed metrics


@pytest.fixture
def gap_case():
    """One gt object in frames 1-4; tracked as 5, 5, (missed; an FP elsewhere), then as 6."""
    gt = dets([B] * 4, [1] * 4, [1, 2, 3, 4], class_id=PED)
    tr = dets([B, B, FAR, B], [5, 5, 9, 6], [1, 2, 3, 4])
    return gt, tr


def test_hand_computed_clear_identity_hota(gap_case):
    m = evaluate_sequence(*gap_case, "mot15")
    # CLEAR: TP 3, FN 1 (frame 3), FP 1 (the far box), one ID switch 5 -> 6 across the gap
    assert (m["CLR_TP"], m["CLR_FN"], m["CLR_FP"], m["IDSW"], m["Frag"]) == (3, 1, 1, 1, 1)
    assert m["MOTA"] == approx((3 - 1 - 1) / 4)
    assert m["MODA"] == approx((3 - 1) / 4)
    assert m["MOTP"] == approx(1.0)
    assert (m["MT"], m["PT"], m["ML"]) == (0, 1, 0)  # tracked 3/4 = 75 %: partly tracked
    # Identity: gt 1 <-> track 5 (2 frames); IDFN = 4 - 2, IDFP = 4 - 2
    assert (m["IDTP"], m["IDFN"], m["IDFP"]) == (2, 2, 2)
    assert m["IDF1"] == approx(0.5) and m["IDR"] == approx(0.5) and m["IDP"] == approx(0.5)
    # HOTA (IoU 1, so the same at every alpha): DetA = 3 / (3 + 1 + 1);
    # AssA = (2 * 2/(4+2-2) + 1 * 1/(4+1-1)) / 3 = 5/12; HOTA = sqrt(3/5 * 5/12) = 1/2
    assert m["DetA"] == approx(0.6)
    assert m["AssA"] == approx(5 / 12)
    assert m["AssRe"] == approx(5 / 12) and m["AssPr"] == approx(1.0)
    assert m["DetRe"] == approx(0.75) and m["DetPr"] == approx(0.75)
    assert m["HOTA"] == approx(0.5)
    assert m["OWTA"] == approx(math.sqrt(0.75 * 5 / 12))
    assert m["LocA"] == approx(1.0)
    assert (
        m["HOTA(0)"] == approx(0.5)
        and m["LocA(0)"] == approx(1.0)
        and m["HOTALocA(0)"] == approx(0.5)
    )
    np.testing.assert_allclose(m.per_alpha["HOTA"], np.full(19, 0.5), rtol=1e-12)
    np.testing.assert_array_equal(m.per_alpha["HOTA_TP"], np.full(19, 3.0))
    assert (m["Dets"], m["GT_Dets"], m["IDs"], m["GT_IDs"]) == (4, 4, 3, 1)


def test_legacy_kitti_idsw_differs_across_a_gap(gap_case):
    """The old KITTI devkit counts no switch when the object was untracked the frame before."""
    te = evaluate_sequence(*gap_case, "mot15", idsw_mode="trackeval")
    legacy = evaluate_sequence(*gap_case, "mot15", idsw_mode="kitti_legacy")
    assert te["IDSW"] == 1 and legacy["IDSW"] == 0
    assert (
        legacy["Frag"] == 1
    )  # id 6 differs from the untracked previous frame, last frame: a fragment
    assert legacy["MOTA"] == approx((3 - 1 - 0) / 4)
    assert legacy["sMOTA"] == approx((3 - 1 - 0) / 4)
    for f in ("MODA", "IDF1", "HOTA", "CLR_TP", "CLR_FP", "MT"):  # only IDSW-based fields change
        assert legacy[f] == te[f]
    assert legacy.idsw_mode == "kitti_legacy"


def test_legacy_and_trackeval_agree_on_consecutive_switch():
    gt = dets([B] * 3, [1] * 3, [1, 2, 3], class_id=PED)
    tr = dets([B] * 3, [5, 6, 6], [1, 2, 3])
    for mode in ("trackeval", "kitti_legacy"):
        m = evaluate_sequence(gt, tr, "mot15", idsw_mode=mode)
        assert m["IDSW"] == 1, mode
        assert m["MOTA"] == approx(2 / 3)


def test_legacy_kitti_no_switch_after_ignored_frame():
    """KITTI: frame 1 of the car is heavily occluded (ignored). TrackEval still counts 10 -> 11 as
    a switch; the legacy devkit resets its memory at ignored frames and counts none."""
    gt = dets(
        [B, B, B],
        [0, 0, 0],
        [0, 1, 2],
        class_id=CAR,
        data={"occluded": [0, 3, 0], "truncated": [0.0, 0.0, 0.0]},
    )
    big = [0.0, 0.0, 40.0, 40.0]
    gt = gt.with_(xyxy=[big] * 3)
    tr = dets([big] * 3, [10, 10, 11], [0, 1, 2], class_id=CAR)
    te = evaluate_sequence(gt, tr, "kitti-car")
    legacy = evaluate_sequence(gt, tr, "kitti-car", idsw_mode="kitti_legacy")
    assert (te["CLR_TP"], te["CLR_FP"], te["CLR_FN"]) == (
        2,
        0,
        0,
    )  # the box on the ignored gt is removed
    assert te["IDSW"] == 1 and te["Frag"] == 0
    assert legacy["IDSW"] == 0 and legacy["Frag"] == 1


def test_perfect_tracking_scores_one():
    gt = dets([B, FAR, B, FAR], [1, 2, 1, 2], [1, 1, 2, 2], class_id=PED)
    m = evaluate_sequence(gt, gt.with_(tracker_id=[7, 8, 7, 8]), "mot17")
    for f in ("MOTA", "MOTP", "IDF1", "HOTA", "DetA", "AssA", "LocA", "CLR_Re", "CLR_Pr", "MTR"):
        assert m[f] == approx(1.0), f
    assert (m["IDSW"], m["Frag"], m["CLR_FP"], m["CLR_FN"]) == (0, 0, 0, 0)


def test_iou_threshold_is_inclusive_and_hota_alphas():
    """IoU exactly 0.5 is a CLEAR match; HOTA counts it for alpha 0.05 .. 0.50 (10 of 19)."""
    gt = dets([B], [1], [1], class_id=PED)
    tr = dets([[0, 0, 10, 5]], [1], [1])
    m = evaluate_sequence(gt, tr, "mot15")
    assert m["CLR_TP"] == 1 and m["MOTP"] == approx(0.5)
    np.testing.assert_array_equal(m.per_alpha["HOTA_TP"], [1.0] * 10 + [0.0] * 9)
    assert m["DetA"] == approx(10 / 19)
    assert len(ALPHAS) == 19


def test_no_plus_one_pixel_convention(tmp_path):
    """MOT boxes x,y,w,h -> corners x, y, x+w, y+h, IoU without +1: these 2x2 boxes shifted by 1
    have IoU 1/3 (with the old +1 convention it would be 0.5, a match)."""
    seq = tmp_path / "S" / "gt"
    seq.mkdir(parents=True)
    (seq / "gt.txt").write_text("1,1,0,0,2,2,1,1,1\n")
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "S.txt").write_text("1,7,1,0,2,2,1,-1,-1,-1\n")
    report = evaluate(load_mot_benchmark(tmp_path, tmp_path / "res"), "mot17")
    assert (report["S"]["CLR_TP"], report["S"]["CLR_FP"], report["S"]["CLR_FN"]) == (0, 1, 1)


def test_mot17_preprocessing():
    """Only class 1 with consider flag 1 is gt; a box on a distractor (static person) is removed;
    a box on an ignored (flag 0) pedestrian stays and is a false positive."""
    gt = dets(
        [[0, 0, 10, 20], [50, 0, 60, 20], [100, 0, 110, 20]],
        [1, 2, 3],
        [1, 1, 1],
        class_id=[PED, CLASS_IDS["static_person"], PED],
        data={"consider": [1, 1, 0]},
    )
    tr = dets(
        [[0, 0, 10, 20], [50, 0, 60, 20], [100, 0, 110, 20], [200, 0, 210, 20]],
        [1, 2, 3, 4],
        [1] * 4,
    )
    m = evaluate_sequence(gt, tr, "mot17")
    assert (m["GT_Dets"], m["Dets"], m["CLR_TP"], m["CLR_FP"], m["CLR_FN"]) == (1, 3, 1, 2, 0)
    assert m["MOTA"] == approx(-1.0)
    # MOT15 rules: no classes, no distractor removal, flag-0 rows still dropped
    m15 = evaluate_sequence(gt, tr, "mot15")
    assert (m15["GT_Dets"], m15["Dets"], m15["CLR_TP"], m15["CLR_FP"]) == (2, 4, 2, 2)


def test_kitti_preprocessing():
    big = lambda x: [x, 0.0, x + 50.0, 50.0]  # noqa: E731
    gt = dets(
        [big(0), big(100), big(200), [300, 0, 400, 100], big(0)],
        [0, 1, 2, -1, 3],
        [0] * 5,
        class_id=[CAR, CAR, VAN, DONTCARE, PED],
        data={"occluded": [0, 3, 0, -1, 0], "truncated": [0.0, 0.0, 0.0, -1.0, 0.0]},
    )
    tr = dets(
        [
            big(0),
            big(100),
            big(200),
            [310, 10, 360, 60],
            [500, 0, 520, 20],
            [600, 0, 700, 100],
            big(0),
        ],
        [10, 11, 12, 13, 14, 15, 16],
        [0] * 7,
        class_id=[CAR] * 6 + [PED],
    )
    car = evaluate_sequence(gt, tr, "kitti-car")
    # kept: 10 (TP) and 15 (FP); removed: 11 (on occluded car), 12 (on van), 13 (in DontCare),
    # 14 (20 px tall); 16 is a pedestrian
    assert (car["GT_Dets"], car["Dets"], car["CLR_TP"], car["CLR_FP"], car["CLR_FN"]) == (
        1,
        2,
        1,
        1,
        0,
    )
    assert car["MOTA"] == approx(0.0)
    ped = evaluate_sequence(gt, tr, "kitti-pedestrian")
    assert (ped["GT_Dets"], ped["Dets"], ped["CLR_TP"]) == (1, 1, 1)


def test_empty_sequences_follow_trackeval_early_return():
    """TrackEval leaves the ratios of a sequence without tracker (or gt) boxes at 0; combining
    recomputes them from the counts."""
    gt = dets([B, B], [1, 1], [1, 2], class_id=PED)
    m = evaluate_sequence(gt, Detections.empty(), "mot17", n_frames=2)
    assert (m["CLR_FN"], m["ML"], m["MLR"], m["MOTA"], m["HOTA"], m["LocA"]) == (
        2,
        1,
        1.0,
        0.0,
        0.0,
        1.0,
    )
    only_fp = evaluate_sequence(Detections.empty(), dets([B], [3], [1]), "mot17", n_frames=2)
    assert (only_fp["CLR_FP"], only_fp["MOTA"], only_fp["MLR"]) == (1, 0.0, 1.0)
    both = SequenceMetrics.combine([m, only_fp])
    assert both["MOTA"] == approx((0 - 1 - 0) / 2)
    assert both.name == COMBINED


def test_combine_sums_counts_and_weights_hota(gap_case):
    a = evaluate_sequence(*gap_case, "mot15", name="a")
    gt2 = dets([B], [1], [1], class_id=PED)
    b = evaluate_sequence(gt2, dets([[0, 0, 10, 5]], [1], [1]), "mot15", name="b")
    c = SequenceMetrics.combine([a, b])
    assert c["CLR_TP"] == a["CLR_TP"] + b["CLR_TP"] and c["IDTP"] == a["IDTP"] + b["IDTP"]
    assert c["MOTA"] == approx((4 - 1 - 1) / 5)
    tp_a, tp_b = a.per_alpha["HOTA_TP"], b.per_alpha["HOTA_TP"]
    ass = (a.per_alpha["AssA"] * tp_a + b.per_alpha["AssA"] * tp_b) / np.maximum(1, tp_a + tp_b)
    np.testing.assert_allclose(c.per_alpha["AssA"], ass, rtol=1e-12)
    det = (tp_a + tp_b) / (
        tp_a
        + tp_b
        + a.per_alpha["HOTA_FN"]
        + b.per_alpha["HOTA_FN"]
        + a.per_alpha["HOTA_FP"]
        + b.per_alpha["HOTA_FP"]
    )
    np.testing.assert_allclose(c.per_alpha["HOTA"], np.sqrt(det * ass), rtol=1e-12)
    assert c["HOTA"] == approx(float(np.mean(np.sqrt(det * ass))))


def test_boxes_outside_the_image_are_scored_as_given():
    box = [-20.0, -10.0, 15.0, 30.0]
    gt = dets([box], [1], [1], class_id=PED)
    m = evaluate_sequence(gt, dets([box], [4], [1]), "mot17")
    assert m["CLR_TP"] == 1 and m["MOTP"] == approx(1.0)


# ---------------------------------------------------------------------------------------------
# properties


@st.composite
def scenes(draw):
    n_obj = draw(st.integers(1, 5))
    n_frames = draw(st.integers(1, 6))
    boxes, ids, frames = [], [], []
    for f in range(1, n_frames + 1):
        for i in range(n_obj):
            if draw(st.booleans()):
                x, y = draw(st.integers(0, 200)), draw(st.integers(0, 200))
                w, h = draw(st.integers(5, 60)), draw(st.integers(5, 60))
                boxes.append([x, y, x + w, y + h])
                ids.append(i + 1)
                frames.append(f)
    return dets(boxes, ids, frames, class_id=PED) if boxes else dets([B], [1], [1], class_id=PED)


@settings(max_examples=40, deadline=None)
@given(scenes(), st.permutations(list(range(10, 20))))
def test_properties_perfect_and_relabelled(gt, perm):
    ids = np.asarray(perm)[gt.tracker_id - 1]
    m = evaluate_sequence(gt, gt.with_(tracker_id=ids), "mot17")
    assert m["IDSW"] == 0 and m["CLR_FN"] == 0 and m["CLR_FP"] == 0
    assert m["MOTA"] == approx(1.0) and m["IDF1"] == approx(1.0)
    assert m["DetA"] == approx(1.0) and m["LocA"] == approx(1.0)
    assert 0.0 <= m["AssA"] <= 1.0 + 1e-12  # < 1 only when two objects overlap fully


@settings(max_examples=30, deadline=None)
@given(scenes(), scenes())
def test_properties_fractions_in_range(gt, tr):
    m = evaluate_sequence(gt, tr.with_(tracker_id=tr.tracker_id + 100), "mot17")
    for f in (
        "HOTA",
        "DetA",
        "AssA",
        "LocA",
        "MOTP",
        "IDF1",
        "IDR",
        "IDP",
        "CLR_Re",
        "CLR_Pr",
        "MTR",
        "PTR",
        "MLR",
    ):
        assert -1e-12 <= m[f] <= 1 + 1e-12, f
    assert m["MOTA"] <= 1.0 and m["CLR_TP"] + m["CLR_FN"] == m["GT_Dets"]
    assert m["CLR_TP"] + m["CLR_FP"] == m["Dets"] and m["IDTP"] <= m["CLR_TP"] + m["Dets"]


# ---------------------------------------------------------------------------------------------
# rules, results objects, errors


def test_rules_by_name():
    assert get_rules("MOT17").gt_class == PED
    assert get_rules("kitti_car").tracker_class == CAR
    assert [r.class_name for r in rules_for_benchmark("kitti")] == ["car", "pedestrian"]
    assert [r.label for r in rules_for_benchmark("kitti", ["pedestrian"])] == ["kitti/pedestrian"]
    with pytest.raises(ValueError, match="kitti-car"):
        get_rules("kitti")
    with pytest.raises(ValueError, match="pedestrian"):
        rules_for_benchmark("mot17", ["car"])
    with pytest.raises(ValueError, match="threshold"):
        DatasetRules(benchmark="x", class_name="y", gt_class=1, threshold=0.0)


def test_report_json_and_table(gap_case):
    gt, tr = gap_case
    report = evaluate({"s1": (gt, tr), "s2": (gt, tr, 4)}, "mot15", idsw_mode="kitti_legacy")
    assert report.sequences == ["s1", "s2"] and report.classes == ["pedestrian"]
    data = json.loads(report.to_json())
    assert data["idsw_mode"] == "kitti_legacy" and data["benchmark"] == "mot15"
    s1 = data["classes"]["pedestrian"]["sequences"]["s1"]
    assert s1["HOTA"] == approx(0.5) and s1["IDSW"] == 0 and isinstance(s1["IDSW"], int)
    assert len(s1["per_alpha"]["HOTA"]) == 19
    assert data["classes"]["pedestrian"]["combined"]["CLR_TP"] == 6
    text = report.table()
    assert "idsw_mode: kitti_legacy" in text
    row = next(line for line in text.splitlines() if line.startswith("s1"))
    assert row.split()[1] == "50.000"  # HOTA as a percentage
    assert report.combined()["CLR_TP"] == 6 and report["s1"]["IDSW"] == 0
    m = report["s1"]
    assert set(m) >= {"MOTA", "IDF1", "HOTA", "HOTA(0)", "Dets", "GT_IDs", "sMOTA"} and len(
        m
    ) == len(list(m))
    with pytest.raises(KeyError):
        m["HOTA_TP"]


def test_kitti_report_has_both_classes():
    gt = dets([[0, 0, 40, 40], [100, 0, 140, 60]], [0, 1], [0, 0], class_id=[CAR, PED])
    tr = gt.with_(tracker_id=[5, 6])
    report = evaluate({"0000": (gt, tr, 1)}, "kitti")
    assert report.classes == ["car", "pedestrian"]
    assert report.combined("car")["MOTA"] == approx(1.0) and report.combined("pedestrian")[
        "IDF1"
    ] == approx(1.0)
    with pytest.raises(KeyError):
        report.combined()


def test_input_errors():
    gt = dets([B, B], [1, 1], [1, 2], class_id=PED, source_row=[3, 4])
    with pytest.raises(InputError, match=r"frame 5 is outside the sequence \(frames 1\.\.3"):
        evaluate_sequence(gt, dets([B], [2], [5], source_row=[7]), "mot17", n_frames=3)
    with pytest.raises(InputError, match="id 2 occurs more than once in frame 1"):
        evaluate_sequence(gt, dets([B, FAR], [2, 2], [1, 1]), "mot17")
    with pytest.raises(InputError, match="negative track id"):
        evaluate_sequence(gt, dets([B], [-1], [1]), "mot17")
    with pytest.raises(InputError, match="only pedestrians"):
        evaluate_sequence(gt, dets([B], [1], [1], class_id=CAR), "mot17")
    with pytest.raises(InputError, match="not finite"):
        evaluate_sequence(gt, dets([[0, 0, np.nan, 1]], [1], [1]), "mot17")
    with pytest.raises(InputError, match="ground-truth class 99 is not a MOT17 class"):
        evaluate_sequence(gt.with_(class_id=[PED, 99]), dets([B], [1], [1]), "mot17")
    with pytest.raises(ValueError, match="idsw_mode"):
        evaluate_sequence(gt, gt, "mot17", idsw_mode="devkit")
    # KITTI drops negative ids instead (DontCare rows have id -1)
    m = evaluate_sequence(
        gt.with_(frame=[0, 1], class_id=CAR, xyxy=[[0, 0, 40, 40]] * 2),
        dets([[0, 0, 40, 40]], [-1], [0], class_id=CAR),
        "kitti-car",
    )
    assert m["Dets"] == 0 and m["CLR_FN"] == 2


# ---------------------------------------------------------------------------------------------
# benchmark folders


def _mot_layout(root, n_frames=3):
    for name in ("A", "B"):
        (root / "gt" / name / "gt").mkdir(parents=True)
        (root / "gt" / name / "gt" / "gt.txt").write_text(
            "1,1,0,0,10,10,1,1,1\n2,1,0,0,10,10,1,1,1\n"
        )
        (root / "gt" / name / "seqinfo.ini").write_text(
            f"[Sequence]\nname={name}\nseqLength={n_frames}\nimWidth=640\nimHeight=480\nframeRate=30\n"
        )
    (root / "res").mkdir()
    (root / "res" / "A.txt").write_text("1,3,0,0,10,10,1,-1,-1,-1\n2,3,0,0,10,10,1,-1,-1,-1\n")
    return root / "gt", root / "res"


def test_load_mot_benchmark_and_errors(tmp_path):
    gt, res = _mot_layout(tmp_path)
    with pytest.raises(InputError, match=r"no results for 1 sequence\(s\): B\.txt"):
        load_mot_benchmark(gt, res)
    seqs = load_mot_benchmark(gt, res, missing_as_empty=True)
    assert list(seqs) == ["A", "B"] and seqs["A"].n_frames == 3 and len(seqs["B"].tracks) == 0
    report = evaluate(seqs, "mot17")
    assert report["A"]["MOTA"] == approx(1.0) and report["B"]["CLR_FN"] == 2
    assert report.combined()["MOTA"] == approx(0.5)

    seqmap = tmp_path / "seqmap.txt"
    seqmap.write_text("name\nA\n")
    assert read_seqmap(seqmap) == ["A"]
    assert list(load_mot_benchmark(gt, res, seqmap=seqmap)) == ["A"]
    seqmap.write_text("name\nA\nMOT17-99\n")
    with pytest.raises(InputError, match="unknown sequence 'MOT17-99'") as err:
        load_mot_benchmark(gt, res, seqmap=seqmap)
    assert err.value.line == 3 and err.value.path == str(seqmap)

    (res / "A.txt").write_text("1,3,0,0,10,10,1,-1,-1,-1\n9,3,0,0,10,10,1,-1,-1,-1\n")
    seqmap.write_text("A\n")
    seqs = load_mot_benchmark(gt, res, seqmap=seqmap)
    with pytest.raises(InputError, match="frame 9 is outside the sequence") as err:
        evaluate(seqs, "mot17")
    assert err.value.path == str(res / "A.txt") and err.value.line == 2


def test_load_kitti_benchmark(tmp_path):
    (tmp_path / "label_02").mkdir()
    label = (
        "0 -1 DontCare -1 -1 -10 300 0 400 100 -1 -1 -1 -1000 -1000 -1000 -10\n"
        "0 0 Car 0 0 0 0 0 50 50 1 1 1 1 1 1 0\n"
        "1 0 Car 0 0 0 0 0 50 50 1 1 1 1 1 1 0\n"
    )
    (tmp_path / "label_02" / "0000.txt").write_text(label)
    (tmp_path / "seqinfo.csv").write_text(
        "seq,num_frames,im_width,im_height,frame_rate\n0000,2,1242,375,10\n"
    )
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "0000.txt").write_text(
        "0 4 Car -1 -1 -10 0 0 50 50 -1 -1 -1 -1000 -1000 -1000 -10 0.9\n"
        "0 5 Car -1 -1 -10 310 10 360 60 -1 -1 -1 -1000 -1000 -1000 -10 0.9\n"
        "1 4 Car -1 -1 -10 0 0 50 50 -1 -1 -1 -1000 -1000 -1000 -10 0.9\n"
    )
    seqs = load_kitti_benchmark(tmp_path, tmp_path / "res")
    assert seqs["0000"].n_frames == 2
    report = evaluate(seqs, "kitti")
    car = report.results["car"]["0000"]
    assert (car["CLR_TP"], car["CLR_FP"], car["IDSW"]) == (2, 0, 0)  # the DontCare box is removed
    assert report.results["pedestrian"]["0000"]["Dets"] == 0
    (tmp_path / "res" / "0000.txt").write_text(
        "2 4 Car -1 -1 -10 0 0 50 50 -1 -1 -1 -1000 -1000 -1000 -10 0.9\n"
    )
    with pytest.raises(InputError, match=r"frame 2 is outside the sequence \(frames 0\.\.1"):
        evaluate(load_kitti_benchmark(tmp_path, tmp_path / "res"), "kitti")


def _devkit_loop(trajectories):
    """The old KITTI devkit's per-trajectory ID-switch / fragmentation loop, transcribed as is."""
    ids = frags = 0
    for g, ign_g in trajectories:
        if all(ign_g) or all(x == -1 for x in g):
            continue
        last_id = g[0]
        f = 0
        for f in range(1, len(g)):
            if ign_g[f]:
                last_id = -1
                continue
            if last_id != g[f] and last_id != -1 and g[f] != -1 and g[f - 1] != -1:
                ids += 1
            if (
                f < len(g) - 1
                and g[f - 1] != g[f]
                and last_id != -1
                and g[f] != -1
                and g[f + 1] != -1
            ):
                frags += 1
            if g[f] != -1:
                last_id = g[f]
        if len(g) > 1 and g[f - 1] != g[f] and last_id != -1 and g[f] != -1 and not ign_g[f]:
            frags += 1
    return ids, frags


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.lists(st.tuples(st.integers(-1, 3), st.booleans()), min_size=1, max_size=12),
        min_size=1,
        max_size=5,
    )
)
def test_legacy_rule_matches_devkit_loop(trajs):
    from sensemaking.evaluation.metrics import legacy_idsw_frag

    key = np.concatenate([np.full(len(t), k) for k, t in enumerate(trajs)])
    frame = np.concatenate(
        [np.arange(len(t))[::-1] * 3 for t in trajs]
    )  # any order in, frame order used
    value = np.concatenate([[v for v, _ in t][::-1] for t in trajs])
    ign = np.concatenate([[i for _, i in t][::-1] for t in trajs]).astype(bool)
    expected = _devkit_loop([([v for v, _ in t], [i for _, i in t]) for t in trajs])
    assert legacy_idsw_frag(key, frame, value, ign) == expected

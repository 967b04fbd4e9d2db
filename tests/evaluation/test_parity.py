"""Parity of sensemaking.evaluation with TrackEval (the ``trackeval`` package): every field, 1e-6.

Needs ``../shared/data`` (benchmark annotations, never committed) and the dev dependency
``trackeval``; skipped cleanly without them. TrackEval reads its own folder layout, which each
test writes into a temporary directory. Tracker outputs for the benchmarks are the ground truth
itself, perturbed deterministically (rows dropped, gaps cut, ids changed and swapped, boxes
jittered, false positives added, boxes put on distractors and DontCare regions), so every count
(IDSW, Frag, FP, FN, distractor removals) is non-trivial.
"""

from __future__ import annotations

import contextlib
import io
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.evaluation import COMBINED, evaluate, load_kitti_benchmark, load_mot_benchmark

pytestmark = pytest.mark.integration

if not SHARED_DATA.is_dir():  # pragma: no cover - depends on the checkout
    pytest.skip(f"benchmark data not found at {SHARED_DATA}", allow_module_level=True)
trackeval = pytest.importorskip("trackeval")

from sensemaking.io.kitti import read_kitti_labels, read_kitti_seqinfo, write_kitti  # noqa: E402
from sensemaking.io.mot import read_mot, read_seqinfo, write_mot  # noqa: E402

TOL = 1e-6
CAR, VAN, PED, DONTCARE = (
    CLASS_IDS["car"],
    CLASS_IDS["van"],
    CLASS_IDS["pedestrian"],
    CLASS_IDS["dontcare"],
)

MOT17_SEQS = ["MOT17-02-YOLOX-half", "MOT17-05-FRCNN", "MOT17-09-YOLOX-half"]
MOT15_SEQS = [
    "ETH-Bahnhof",
    "PETS09-S2L1",
    "TUD-Campus",
]  # the first two have consider-flag-0 rows
KITTI_SEQS = ["0000", "0001", "0004", "0010"]  # cars in all, pedestrians in all


# ---------------------------------------------------------------------------------------------
# TrackEval runners


def _evaluator():
    return trackeval.Evaluator(
        {
            "USE_PARALLEL": False,
            "PRINT_RESULTS": False,
            "PRINT_CONFIG": False,
            "OUTPUT_SUMMARY": False,
            "OUTPUT_DETAILED": False,
            "PLOT_CURVES": False,
            "TIME_PROGRESS": False,
            "LOG_ON_ERROR": None,
            "BREAK_ON_ERROR": True,
        }
    )


def _metrics():
    return [
        trackeval.metrics.HOTA(),
        trackeval.metrics.CLEAR({"PRINT_CONFIG": False}),
        trackeval.metrics.Identity({"PRINT_CONFIG": False}),
    ]  # Count is always added


def trackeval_mot(tmp: Path, seqs: dict[str, tuple[Path, Path, int]], benchmark: str) -> dict:
    """TrackEval's MotChallenge2DBox on name -> (gt.txt, results.txt, length)."""
    gt_root, trackers = tmp / "te_gt", tmp / "te_trackers"
    (trackers / "T" / "data").mkdir(parents=True)
    for name, (gt, res, n) in seqs.items():
        (gt_root / name / "gt").mkdir(parents=True)
        shutil.copy(gt, gt_root / name / "gt" / "gt.txt")
        (gt_root / name / "seqinfo.ini").write_text(f"[Sequence]\nname={name}\nseqLength={n}\n")
        shutil.copy(res, trackers / "T" / "data" / f"{name}.txt")
    dataset = trackeval.datasets.MotChallenge2DBox(
        {
            "GT_FOLDER": str(gt_root),
            "TRACKERS_FOLDER": str(trackers),
            "OUTPUT_FOLDER": str(tmp / "te_out"),
            "BENCHMARK": benchmark,
            "SKIP_SPLIT_FOL": True,
            "TRACKERS_TO_EVAL": ["T"],
            "PRINT_CONFIG": False,
            "SEQ_INFO": {name: n for name, (_, _, n) in seqs.items()},
        }
    )
    with contextlib.redirect_stdout(io.StringIO()):
        res, _ = _evaluator().evaluate([dataset], _metrics())
    return res["MotChallenge2DBox"]["T"]


def trackeval_kitti(
    tmp: Path, seqs: dict[str, tuple[Path, Path, int]], classes: list[str]
) -> dict:
    """TrackEval's Kitti2DBox on name -> (label file, results file, length)."""
    gt_root, trackers = tmp / "te_gt", tmp / "te_trackers"
    (gt_root / "label_02").mkdir(parents=True)
    (trackers / "T" / "data").mkdir(parents=True)
    lines = []
    for name, (gt, res, n) in seqs.items():
        lines.append(f"{name} empty 000000 {n:06d}\n")
        shutil.copy(gt, gt_root / "label_02" / f"{name}.txt")
        shutil.copy(res, trackers / "T" / "data" / f"{name}.txt")
    (gt_root / "evaluate_tracking.seqmap.training").write_text("".join(lines))
    dataset = trackeval.datasets.Kitti2DBox(
        {
            "GT_FOLDER": str(gt_root),
            "TRACKERS_FOLDER": str(trackers),
            "OUTPUT_FOLDER": str(tmp / "te_out"),
            "CLASSES_TO_EVAL": classes,
            "TRACKERS_TO_EVAL": ["T"],
            "PRINT_CONFIG": False,
        }
    )
    with contextlib.redirect_stdout(io.StringIO()):
        res, _ = _evaluator().evaluate([dataset], _metrics())
    return res["Kitti2DBox"]["T"]


def max_differences(te_res: dict, ours) -> dict[str, float]:
    """Field -> max |TrackEval - ours| over every TrackEval field (arrays over alpha included)."""
    out = {}
    for family, part in (
        ("HOTA", "hota"),
        ("CLEAR", "clear"),
        ("Identity", "identity"),
        ("Count", "count"),
    ):
        for field, value in te_res[family].items():
            if field == "Frames":  # per-sequence only in TrackEval's Count; not a metric
                continue
            assert field in ours.parts[part], f"{family}.{field} missing"
            out[field] = float(
                np.max(
                    np.abs(np.asarray(value, float) - np.asarray(ours.parts[part][field], float))
                )
            )
    return out


def assert_parity(te_by_seq: dict, report, class_name: str, sequences: list[str]) -> float:
    worst = 0.0
    for seq in sequences + [COMBINED]:
        te = te_by_seq["COMBINED_SEQ" if seq == COMBINED else seq][class_name]
        diffs = max_differences(te, report.results[class_name][seq])
        bad = {k: v for k, v in diffs.items() if not v <= TOL}
        assert not bad, f"{class_name} {seq}: {bad}"
        worst = max(worst, max(diffs.values()))
    return worst


# ---------------------------------------------------------------------------------------------
# deterministic fake tracker output


def perturb(gt: Detections, seed: int, fp_rate: float = 0.05) -> Detections:
    """Ground truth turned into a flawed tracker output (same frames, new ids, sorted by frame)."""
    rng = np.random.default_rng(seed)
    n = len(gt)
    ids, frames, xyxy = gt.tracker_id.copy(), gt.frame.copy(), gt.xyxy.copy()
    keep = rng.random(n) > 0.08  # isolated misses
    uid = np.unique(ids)
    for i in rng.choice(uid, size=max(1, len(uid) // 4), replace=False):  # gaps -> Frag
        f = frames[ids == i]
        a = rng.integers(f.min(), f.max() + 1)
        keep &= ~((ids == i) & (frames >= a) & (frames < a + rng.integers(2, 12)))
    new_ids = ids * 10 + 1
    for i in rng.choice(
        uid, size=max(1, len(uid) // 3), replace=False
    ):  # new id from some frame on
        f = frames[ids == i]
        new_ids[(ids == i) & (frames >= rng.integers(f.min(), f.max() + 1))] = i * 10 + 2
    for _ in range(max(1, len(uid) // 6)):  # two ids swapped from some frame on
        if len(uid) < 2:
            break
        i, j = rng.choice(uid, size=2, replace=False)
        a = rng.integers(frames.min(), frames.max() + 1)
        mi, mj = (ids == i) & (frames >= a), (ids == j) & (frames >= a)
        new_ids[mi], new_ids[mj] = j * 10 + 3, i * 10 + 3
    w, h = xyxy[:, 2] - xyxy[:, 0], xyxy[:, 3] - xyxy[:, 1]
    size = np.stack([w, h], 1)
    centre = xyxy[:, :2] + size / 2 + rng.normal(0, 0.08, (n, 2)) * size  # jitter around IoU 0.5
    size2 = np.abs(size * (1 + rng.normal(0, 0.12, (n, 2)))) + 1
    boxes = np.round(np.concatenate([centre - size2 / 2, centre + size2 / 2], 1), 2)
    n_fp = int(fp_rate * n)
    src = rng.integers(0, n, n_fp)
    fp = boxes[src] + rng.normal(0, 1, (n_fp, 4)) * np.tile(size2[src], 2)
    fp[:, 2:] = np.maximum(fp[:, 2:], fp[:, :2] + 5)
    out = Detections(
        xyxy=np.concatenate([boxes[keep], np.round(fp, 2)]),
        confidence=np.round(rng.random(int(keep.sum()) + n_fp), 3),
        class_id=np.concatenate([gt.class_id[keep], gt.class_id[src]]),
        tracker_id=np.concatenate(
            [new_ids[keep], 10**6 + rng.integers(0, max(2, n_fp // 3), n_fp)]
        ),
        frame=np.concatenate([frames[keep], frames[src]]),
    )
    return _unique_sorted(out)


def _unique_sorted(d: Detections) -> Detections:
    _, first = np.unique(d.frame * 10**9 + d.tracker_id, return_index=True)
    d = d[np.sort(first)]
    return d[np.argsort(d.frame, kind="stable")]


# ---------------------------------------------------------------------------------------------


def test_fixtures_parity(tmp_path):
    """TUD-Campus and TUD-Stadtmitte with their classic tracker output test.txt (MOT15 rules)."""
    root = SHARED_DATA / "metric-fixtures"
    seqs = {}
    for name, n in (("TUD-Campus", 71), ("TUD-Stadtmitte", 179)):
        (tmp_path / "res").mkdir(exist_ok=True)
        shutil.copy(root / name / "test.txt", tmp_path / "res" / f"{name}.txt")
        seqs[name] = (root / name / "gt.txt", tmp_path / "res" / f"{name}.txt", n)
    te = trackeval_mot(tmp_path, seqs, "MOT15")
    ours = evaluate(
        {
            name: (read_mot(g, kind="gt"), read_mot(r, kind="results"), n)
            for name, (g, r, n) in seqs.items()
        },
        "mot15",
    )
    assert_parity(te, ours, "pedestrian", list(seqs))
    # the classic published numbers for these fixtures
    assert ours["TUD-Campus"]["MOTA"] == pytest.approx(0.526462, abs=1e-6)
    assert ours["TUD-Stadtmitte"]["IDF1"] == pytest.approx(0.644619, abs=1e-6)


@pytest.mark.parametrize("benchmark, names", [("mot17", MOT17_SEQS), ("mot15", MOT15_SEQS)])
@pytest.mark.slow
def test_mot_benchmark_parity(tmp_path, benchmark, names):
    root = SHARED_DATA / benchmark
    res = tmp_path / "res"
    res.mkdir()
    seqs = {}
    for k, name in enumerate(names):
        gt = read_mot(root / name / "gt" / "gt.txt", kind="gt")
        if benchmark == "mot17":  # boxes on pedestrians and on distractors (to be removed)
            gt = gt[np.isin(gt.class_id, [1, 2, 7, 8, 12])]
        tracks = perturb(gt, seed=100 + k).with_(class_id=1)
        write_mot(res / f"{name}.txt", tracks)
        seqs[name] = (
            root / name / "gt" / "gt.txt",
            res / f"{name}.txt",
            read_seqinfo(root / name).length,
        )
    te = trackeval_mot(tmp_path, seqs, benchmark.upper())
    ours = evaluate(load_mot_benchmark(root, res, seqmap=_seqmap(tmp_path, names)), benchmark)
    assert assert_parity(te, ours, "pedestrian", names) <= TOL
    c = ours.combined()
    assert c["IDSW"] > 10 and c["Frag"] > 10 and c["CLR_FP"] > 100 and c["CLR_FN"] > 100


def _seqmap(tmp: Path, names: list[str]) -> Path:
    path = tmp / "seqmap.txt"
    path.write_text("name\n" + "".join(f"{n}\n" for n in names))
    return path


@pytest.mark.slow
def test_kitti_parity(tmp_path):
    root = SHARED_DATA / "kitti" / "training"
    info = read_kitti_seqinfo(root / "seqinfo.csv")
    res = tmp_path / "res"
    res.mkdir()
    seqs = {}
    for k, name in enumerate(KITTI_SEQS):
        gt = read_kitti_labels(root / "label_02" / f"{name}.txt")
        rng = np.random.default_rng(200 + k)
        objects = gt[np.isin(gt.class_id, [CAR, VAN, PED]) & (gt.tracker_id >= 0)]
        tracks = perturb(objects, seed=300 + k, fp_rate=0.1)
        cls = tracks.class_id.copy()
        cls[(cls == VAN) & (rng.random(len(cls)) < 0.7)] = (
            CAR  # "cars" on vans: removed as distractors
        )
        dc = gt[gt.class_id == DONTCARE]  # boxes inside DontCare regions: removed
        in_dc = Detections(
            xyxy=np.round(dc.xyxy + rng.normal(0, 2, (len(dc), 4)), 2),
            class_id=np.where(rng.random(len(dc)) < 0.5, CAR, PED),
            tracker_id=5 * 10**6 + np.arange(len(dc)) % 7,
            frame=dc.frame,
            confidence=0.5,
        )
        tracks = _unique_sorted(Detections.concatenate([tracks.with_(class_id=cls), in_dc]))
        ok = (tracks.xyxy[:, 2] > tracks.xyxy[:, 0] + 0.5) & (
            tracks.xyxy[:, 3] > tracks.xyxy[:, 1] + 0.5
        )
        write_kitti(res / f"{name}.txt", tracks[ok])
        seqs[name] = (root / "label_02" / f"{name}.txt", res / f"{name}.txt", info[name].length)
    te = trackeval_kitti(tmp_path, seqs, ["car", "pedestrian"])
    loaded = load_kitti_benchmark(root, res, seqmap=_seqmap(tmp_path, KITTI_SEQS))
    ours = evaluate(loaded, "kitti")
    for class_name in ("car", "pedestrian"):
        assert assert_parity(te, ours, class_name, KITTI_SEQS) <= TOL
    car = ours.combined("car")
    assert car["IDSW"] > 10 and car["Frag"] > 10 and car["CLR_FP"] > 100

    legacy = evaluate(loaded, "kitti", idsw_mode="kitti_legacy")
    lc = legacy.combined("car")
    assert legacy.idsw_mode == "kitti_legacy" and lc["IDSW"] < car["IDSW"]
    assert (
        lc["CLR_TP"] == car["CLR_TP"] and lc["IDF1"] == car["IDF1"] and lc["HOTA"] == car["HOTA"]
    )
    assert lc["MOTA"] - car["MOTA"] == pytest.approx((car["IDSW"] - lc["IDSW"]) / car["GT_Dets"])


# ---------------------------------------------------------------------------------------------
# random adversarial scenes: coarse integer grid (exact ties, IoU exactly 0.5, duplicate boxes),
# empty frames, unsorted ids, every class and flag

_KITTI_TYPES = {
    CAR: "Car",
    VAN: "Van",
    PED: "Pedestrian",
    DONTCARE: "DontCare",
    CLASS_IDS["person_sitting"]: "Person",
}


def _grid_boxes(rng, n: int, scale: int) -> np.ndarray:
    xy = rng.integers(0, 6, (n, 2)) * 4 * scale
    wh = rng.integers(1, 6, (n, 2)) * 4 * scale
    return np.concatenate([xy, wh], 1)


def _random_mot(rng, tmp: Path, benchmark: str, name: str) -> tuple[Path, Path, int]:
    n_frames = int(rng.integers(5, 25))
    gt_lines, tr_lines = [], []
    for f in range(1, n_frames + 1):
        for kind, lines in (("gt", gt_lines), ("tr", tr_lines)):
            if rng.random() < 0.15:
                continue
            n = int(rng.integers(0, 12))
            boxes = _grid_boxes(rng, n, 1)
            if kind == "tr" and n >= 2 and rng.random() < 0.3:
                boxes[1] = boxes[0]
            ids = rng.choice(np.arange(1, 16), n, replace=False)
            for (x, y, w, h), i in zip(boxes.tolist(), ids.tolist(), strict=True):
                if kind == "tr":
                    lines.append(f"{f},{i},{x},{y},{w},{h},1,-1,-1,-1")
                elif benchmark == "MOT17":
                    cls = int(rng.choice([1, 1, 1, 2, 7, 8, 12, 3, 9]))
                    lines.append(f"{f},{i},{x},{y},{w},{h},{int(rng.random() > 0.15)},{cls},1")
                else:
                    lines.append(f"{f},{i},{x},{y},{w},{h},{int(rng.random() > 0.15)},-1,-1,-1")
    (tmp / "gt" / name / "gt").mkdir(parents=True)
    gt = tmp / "gt" / name / "gt" / "gt.txt"
    gt.write_text("".join(line + "\n" for line in gt_lines))
    (tmp / "gt" / name / "seqinfo.ini").write_text(
        f"[Sequence]\nname={name}\nseqLength={n_frames}\nimWidth=99\nimHeight=99\nframeRate=1\n"
    )
    res = tmp / "res" / f"{name}.txt"
    res.write_text("".join(line + "\n" for line in tr_lines))
    return gt, res, n_frames


def _random_kitti(rng, tmp: Path, name: str) -> tuple[Path, Path, Path, int]:
    n_frames = int(rng.integers(5, 25))
    gt_lines, tr_lines = [], []
    for f in range(n_frames):
        n = int(rng.integers(0, 12))
        ids = rng.choice(np.arange(0, 16), n, replace=False)
        for (x, y, w, h), i in zip(_grid_boxes(rng, n, 3).tolist(), ids.tolist(), strict=True):
            cls = int(
                rng.choice([CAR, CAR, CAR, VAN, PED, PED, DONTCARE, CLASS_IDS["person_sitting"]])
            )
            i = -1 if cls == DONTCARE else i
            gt_lines.append(
                f"{f} {i} {_KITTI_TYPES[cls]} "
                f"{rng.choice([0, 0, 0, 1, 2])} {rng.integers(0, 4)} 0 "
                f"{x} {y} {x + w} {y + h} 1 1 1 1 1 1 0"
            )
        n = int(rng.integers(0, 12))
        boxes = _grid_boxes(rng, n, 3)
        if n >= 2 and rng.random() < 0.3:
            boxes[1] = boxes[0]
        ids = rng.choice(np.arange(0, 16), n, replace=False)
        for (x, y, w, h), i in zip(boxes.tolist(), ids.tolist(), strict=True):
            kind = _KITTI_TYPES[int(rng.choice([CAR, CAR, PED, VAN]))]
            tr_lines.append(
                f"{f} {i} {kind} -1 -1 -10 {x} {y} {x + w} {y + h} "
                "-1 -1 -1 -1000 -1000 -1000 -10 0.5"
            )
    te_gt = (
        tmp / "te_labels" / f"{name}.txt"
    )  # TrackEval spells person sitting "Person" (as KITTI tracking)
    te_gt.parent.mkdir(exist_ok=True)
    te_gt.write_text("".join(line + "\n" for line in gt_lines))
    ours = tmp / "gt" / "label_02" / f"{name}.txt"
    ours.parent.mkdir(parents=True, exist_ok=True)
    ours.write_text(
        "".join(line.replace(" Person ", " Person_sitting ") + "\n" for line in gt_lines)
    )
    res = tmp / "res" / f"{name}.txt"
    res.write_text("".join(line + "\n" for line in tr_lines))
    return te_gt, ours, res, n_frames


@pytest.mark.parametrize("family", ["MOT17", "MOT15", "KITTI"])
@pytest.mark.parametrize("seed", [0, 1])
def test_random_scenes_parity(tmp_path, family, seed):
    rng = np.random.default_rng([seed, len(family)])
    (tmp_path / "res").mkdir()
    names = [f"{k:04d}" for k in range(4)]
    if family == "KITTI":
        seqs, lengths = {}, {}
        for name in names:
            te_gt, _, res, n = _random_kitti(rng, tmp_path, name)
            seqs[name], lengths[name] = (te_gt, res, n), n
        (tmp_path / "gt" / "seqinfo.csv").write_text(
            "seq,num_frames,im_width,im_height,frame_rate\n"
            + "".join(f"{s},{n},99,99,10\n" for s, n in lengths.items())
        )
        te = trackeval_kitti(tmp_path, seqs, ["car", "pedestrian"])
        ours = evaluate(load_kitti_benchmark(tmp_path / "gt", tmp_path / "res"), "kitti")
        for class_name in ("car", "pedestrian"):
            assert_parity(te, ours, class_name, names)
    else:
        seqs = {name: _random_mot(rng, tmp_path, family, name) for name in names}
        te = trackeval_mot(tmp_path, seqs, family)
        ours = evaluate(load_mot_benchmark(tmp_path / "gt", tmp_path / "res"), family.lower())
        assert_parity(te, ours, "pedestrian", names)

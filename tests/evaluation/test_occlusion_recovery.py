"""Identity through occlusion: our evaluator against the reference checker, count for count.

The reference definition is ``../shared/verify/occlusion_recovery.py``; both judge the same
tracker output (``sensemaking track`` on shared sequences, with and without abduction), and
every count (verdicts, and verdicts by gap bucket) must be equal. Skips without ``../shared``.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.classes import class_id
from sensemaking.detections import Detections
from sensemaking.evaluation.occlusion import (
    BUCKETS,
    OcclusionCounts,
    kitti_episodes,
    mot_episodes,
    mot_windows,
)
from sensemaking.io.kitti import read_kitti_labels
from sensemaking.io.mot import read_mot, read_seqinfo

CHECKER = SHARED_DATA.parent / "verify" / "occlusion_recovery.py"
needs_shared = pytest.mark.skipif(
    not (SHARED_DATA.is_dir() and CHECKER.is_file()), reason="../shared is absent"
)


def _track(tmp: Path, fmt: str, det: Path, out: Path, *extra: str) -> None:
    cmd = [sys.executable, "-m", "sensemaking", "track", "--format", fmt, "--detections"]
    cmd += [str(det), "--output", str(out), *extra]
    subprocess.run(cmd, check=True, capture_output=True, cwd=tmp)


def _checker(args: list[str], tmp: Path) -> dict[str, int]:
    js = tmp / "checker.json"
    cmd = [sys.executable, str(CHECKER), "--json", str(js), *args]
    subprocess.run(cmd, check=True, capture_output=True)
    return json.loads(js.read_text())["ours"]


def _flat(c: OcclusionCounts) -> dict[str, int]:
    """Our counts under the checker's keys (zeros dropped, as a Counter leaves them out)."""
    out = {v: n for v, n in c.counts.items()}
    for b in BUCKETS:
        for v in ("kept", "switched", "lost"):
            out[f"{b}:{v}"] = c.by_gap[b][v]
    return {k: n for k, n in out.items() if n}


KITTI_CASES = [
    ("rrc", "car", ("0001", "0004", "0005")),
    ("rrc", "pedestrian", ("0001", "0004", "0009")),  # the only shared pedestrian episodes
    ("pointrcnn", "car", ("0007", "0009")),
]


@needs_shared
@pytest.mark.parametrize("detector,cls,seqs", KITTI_CASES)
@pytest.mark.parametrize(
    "abduction",
    [
        pytest.param(True, marks=pytest.mark.slow, id="ours"),
        pytest.param(False, marks=pytest.mark.slow, id="no-abduction"),
    ],
)
def test_kitti_counts_equal_the_checker(tmp_path, detector, cls, seqs, abduction):
    kitti = SHARED_DATA / "kitti"
    out = tmp_path / "res"
    ours = OcclusionCounts()
    for seq in seqs:
        extra = () if abduction else ("--no-abduction",)
        det = kitti / "detections" / detector / cls / f"{seq}.txt"
        _track(tmp_path, "kitti", det, out / f"{seq}.txt", "--class", cls, *extra)
        gt = read_kitti_labels(kitti / "training" / "label_02" / f"{seq}.txt")
        tracks = read_kitti_labels(out / f"{seq}.txt")
        ours = ours + OcclusionCounts.of(kitti_episodes(gt, tracks, class_id(cls), name=seq))
    label = str(kitti / "training" / "label_02")
    ref = _checker(["kitti", label, cls.capitalize(), f"ours={out}", "--", *seqs], tmp_path)
    assert ours.episodes > 0
    assert _flat(ours) == ref


@needs_shared
@pytest.mark.slow
@pytest.mark.parametrize("seq", ["MOT17-09-YOLOX-half", "MOT17-05-FRCNN"])
def test_mot_counts_equal_the_checker(tmp_path, seq):
    root = SHARED_DATA / "mot17"
    out = tmp_path / "res"
    _track(tmp_path, "mot", root / seq / "det" / "det.txt", out / f"{seq}.txt", "--no-abduction")
    gt = read_mot(root / seq / "gt" / "gt.txt", kind="gt")
    fps = read_seqinfo(root / seq / "seqinfo.ini").fps
    ours = OcclusionCounts.of(mot_episodes(gt, read_mot(out / f"{seq}.txt", kind="results"), fps))
    ref = _checker(["mot", str(root), f"ours={out}", "--", seq], tmp_path)
    assert ours.episodes > 0
    assert _flat(ours) == ref


@needs_shared
@pytest.mark.slow
def test_evaluate_cli_reports_the_same_counts(tmp_path):
    """`sensemaking evaluate --json` carries the occlusion counts the checker gives, per
    sequence and pooled, and prints them."""
    kitti = SHARED_DATA / "kitti"
    out = tmp_path / "res"
    seqs = ("0001", "0009")
    for seq in seqs:
        det = kitti / "detections" / "rrc" / "car" / f"{seq}.txt"
        _track(tmp_path, "kitti", det, out / f"{seq}.txt", "--class", "car", "--no-abduction")
    seqmap = tmp_path / "seqmap.txt"
    seqmap.write_text("\n".join(seqs) + "\n")
    js = tmp_path / "scores.json"
    cmd = [sys.executable, "-m", "sensemaking", "evaluate", "--gt", str(kitti / "training")]
    cmd += ["--results", str(out), "--benchmark", "kitti", "--classes", "car"]
    cmd += ["--seqmap", str(seqmap), "--json", str(js)]
    done = subprocess.run(cmd, check=True, capture_output=True, text=True)
    assert "Identity through occlusion (kitti / car)" in done.stdout
    occ = json.loads(js.read_text())["occlusion"]["car"]
    label = str(kitti / "training" / "label_02")
    for seq in seqs:
        ref = _checker(["kitti", label, "Car", f"ours={out}", "--", seq], tmp_path)
        got = occ["sequences"][seq]
        assert got["kept"] == ref.get("kept", 0)
        assert got["switched"] == ref.get("switched", 0)
        assert got["lost"] == ref.get("lost", 0)
        assert got["not_tracked_before"] == ref.get("not tracked before", 0)
    pooled = _checker(["kitti", label, "Car", f"ours={out}", "--", *seqs], tmp_path)
    assert occ["pooled"]["episodes"] == sum(
        pooled.get(v, 0) for v in ("kept", "switched", "lost", "not tracked before")
    )
    assert occ["pooled"]["by_gap"]["short"]["kept"] == pooled.get("short:kept", 0)


def _box(x: float) -> list[float]:
    return [x, 100.0, x + 20.0, 150.0]


def test_verdicts_on_a_made_up_kitti_object():
    """Visible at 0, hidden (occluded 2) on 1..4, visible at 5: one episode of gap 4; the
    verdict follows the id on the object at 5 (same, other, none) and at 0 (none: not
    tracked before)."""
    frames = np.arange(6)
    gt = Detections(
        xyxy=np.array([_box(10.0 * f) for f in frames]),
        class_id=np.full(6, 3),
        tracker_id=np.full(6, 7),
        frame=frames,
        data={"occluded": np.array([0, 2, 2, 2, 2, 1])},
    )

    def tracks(ids: dict[int, int]) -> Detections:
        fs = sorted(ids)
        return Detections(
            xyxy=np.array([_box(10.0 * f) for f in fs]).reshape(-1, 4),
            class_id=np.full(len(fs), 3),
            tracker_id=np.array([ids[f] for f in fs], dtype=np.int64),
            frame=np.array(fs, dtype=np.int64),
        )

    def verdict(ids: dict[int, int]) -> str:
        (e,) = kitti_episodes(gt, tracks(ids), 3)
        assert e.gap == 4 and e.bucket == "short"
        return e.verdict

    assert verdict({0: 1, 5: 1}) == "kept"
    assert verdict({0: 1, 5: 2}) == "switched"
    assert verdict({0: 1}) == "lost"
    assert verdict({5: 1}) == "not tracked before"
    # a pedestrian class filter: the same object under class 1 has no episode
    assert kitti_episodes(gt, tracks({0: 1, 5: 1}), 1) == []


def test_mot_windows_follow_the_frame_rate():
    assert mot_windows(30.0) == (6, 10)
    assert mot_windows(14.0) == (3, 5)
    assert mot_windows(25.0) == (5, 9)

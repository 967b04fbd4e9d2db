"""Cross-validation of our parameters: folds are videos, a fold's choice never sees its video."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from sensemaking.benchmark import crossval, datasets
from sensemaking.detections import Detections

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def test_folds_are_videos() -> None:
    specs = {s.name: s for s in datasets.SPECS}
    assert crossval.fold_key(specs["kitti-rrc-car"], "0003") == crossval.fold_key(
        specs["kitti-pointrcnn-pedestrian"], "0003") == "KITTI-0003"
    assert crossval.fold_key(specs["mot17-yolox-halfval"], "MOT17-05-YOLOX-half") == "MOT17-05"
    assert crossval.fold_key(specs["mot17-frcnn"], "MOT17-05-FRCNN") == "MOT17-05"
    assert crossval.fold_key(specs["mot15"], "TUD-Campus") == "TUD-Campus"
    assert crossval.family_of(specs["mot15"]) == "mot" and crossval.family_of(specs["kitti-rrc-car"]) == "kitti"


def test_grid_is_small_and_holds_the_presets() -> None:
    for family, grid in crossval.GRID.items():
        points = crossval.grid_points(grid)
        assert len(points) <= int(np.prod([len(v) for v in grid.values()])) <= 30
        assert all(p["min_confidence"] <= p["start_confidence"] for p in points)
        assert len({tuple(p.items()) for p in points}) == len(points)
        assert crossval._preset_index(family, points) is not None, family


def _bench(names: list[str]) -> datasets.Benchmark:
    found = datasets.discover(DATA, only=["kitti-rrc-pedestrian"])
    (spec, sources), = found.found
    return datasets.load_benchmark(spec, [s for s in sources if s.name in names])


@pytest.mark.integration
@pytest.mark.skipif(not (DATA / "kitti").is_dir(), reason="needs ../shared/data/kitti")
def test_a_fold_never_sees_its_own_video(tmp_path: Path) -> None:
    grid = {"start_confidence": (0.5, 0.8), "min_hits": (1, 3)}
    bench = _bench(["0000", "0002", "0004"])
    cv = crossval.cross_validate([bench], tmp_path / "a", grid=grid)
    assert cv.folds == ["KITTI-0000", "KITTI-0002", "KITTI-0004"] and len(cv.points) == 4
    for fold in cv.folds:
        assert cv.mean_choice[fold] == int(np.argmax(cv.fold_objective[fold]))
        regret = cv.fold_regret[fold]
        assert regret[cv.choice[fold]] == min(regret)  # least worst regret over training videos
    assert cv.in_sample == int(np.argmax(cv.objective_all))
    # wreck sequence 0002 (no detections at all): the choice made without it cannot change
    wrecked = [s if s.name != "0002" else dataclasses.replace(s, detections=s.detections[:0])
               for s in bench.sequences]
    cv2 = crossval.cross_validate([dataclasses.replace(bench, sequences=wrecked)], tmp_path / "b", grid=grid)
    assert cv2.fold_objective["KITTI-0002"] == cv.fold_objective["KITTI-0002"]
    assert cv2.fold_regret["KITTI-0002"] == cv.fold_regret["KITTI-0002"]
    assert cv2.choice["KITTI-0002"] == cv.choice["KITTI-0002"]
    assert cv2.fold_objective["KITTI-0000"] != cv.fold_objective["KITTI-0000"]  # it trains on 0002
    assert cv2.per_sequence[bench.name]["0002"]["cv"] == 0.0  # nothing tracked, nothing found
    # the headline combines every held-out sequence, each with its fold's choice
    name = bench.name
    assert set(cv.per_sequence[name]) == {"0000", "0002", "0004"}
    assert 0.2 < cv.heldout[name]["HOTA"] <= cv.insample[name]["HOTA"] + 0.05
    lo, hi = cv.fold_spread(name)
    assert lo <= hi
    heldout = tmp_path / "a" / "crossval" / name / "heldout"
    assert sorted(p.name for p in heldout.iterdir()) == ["0000.txt", "0002.txt", "0004.txt"]
    assert isinstance(bench.sequences[0].detections, Detections)


def test_one_video_is_not_cross_validated(tmp_path: Path) -> None:
    if not (DATA / "kitti").is_dir():
        pytest.skip("needs ../shared/data/kitti")
    with pytest.raises(ValueError, match="two videos or more"):
        crossval.cross_validate([_bench(["0000"])], tmp_path, grid={"min_hits": (1, 2)})

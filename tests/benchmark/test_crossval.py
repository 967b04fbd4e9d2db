"""Cross-validation of our parameters: folds are videos, a fold's choice never sees its video."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from sensemaking.benchmark import crossval, datasets
from sensemaking.detections import Detections

from conftest import SHARED_DATA



def test_folds_are_videos() -> None:
    specs = {s.name: s for s in datasets.SPECS}
    assert (
        crossval.fold_key(specs["kitti-rrc-car"], "0003")
        == crossval.fold_key(specs["kitti-pointrcnn-pedestrian"], "0003")
        == "KITTI-0003"
    )
    assert crossval.fold_key(specs["mot17-yolox-halfval"], "MOT17-05-YOLOX-half") == "MOT17-05"
    assert crossval.fold_key(specs["mot17-frcnn"], "MOT17-05-FRCNN") == "MOT17-05"
    assert crossval.fold_key(specs["mot15"], "TUD-Campus") == "TUD-Campus"
    assert (
        crossval.family_of(specs["mot15"]) == "mot"
        and crossval.family_of(specs["kitti-rrc-car"]) == "kitti"
    )


def test_grid_is_small_and_holds_the_presets() -> None:
    for family, grid in crossval.GRID.items():
        points = crossval.grid_points(grid)
        assert len(points) <= int(np.prod([len(v) for v in grid.values()])) <= 30
        assert all(p["min_confidence"] <= p["start_confidence"] for p in points)
        assert len({tuple(p.items()) for p in points}) == len(points)
        assert crossval._preset_index(family, points) is not None, family


def _bench(names: list[str]) -> datasets.Benchmark:
    found = datasets.discover(SHARED_DATA, only=["kitti-rrc-pedestrian"])
    ((spec, sources),) = found.found
    return datasets.load_benchmark(spec, [s for s in sources if s.name in names])


@pytest.mark.integration
@pytest.mark.skipif(not (SHARED_DATA / "kitti").is_dir(), reason="needs ../shared/data/kitti")
@pytest.mark.slow
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
    wrecked = [
        s if s.name != "0002" else dataclasses.replace(s, detections=s.detections[:0])
        for s in bench.sequences
    ]
    cv2 = crossval.cross_validate(
        [dataclasses.replace(bench, sequences=wrecked)], tmp_path / "b", grid=grid
    )
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
    if not (SHARED_DATA / "kitti").is_dir():
        pytest.skip("needs ../shared/data/kitti")
    with pytest.raises(ValueError, match="two videos or more"):
        crossval.cross_validate([_bench(["0000"])], tmp_path, grid={"min_hits": (1, 2)})


def test_reports_show_the_crossval_headline(tmp_path: Path) -> None:
    from sensemaking.benchmark import report, runner

    points = crossval.grid_points({"start_confidence": (0.5, 0.8), "min_hits": (1, 3)})
    cv = crossval.FamilyCV(
        family="kitti",
        grid={"start_confidence": [0.5, 0.8], "min_hits": [1, 3]},
        points=points,
        benchmarks=["kitti-rrc-car"],
        sequences={"kitti-rrc-car": ["0000", "0001"]},
        folds=["KITTI-0000", "KITTI-0001"],
        choice={"KITTI-0000": 1, "KITTI-0001": 3},
        fold_regret={"KITTI-0000": [0.1, 0.0, 0.2, 0.3], "KITTI-0001": [0.1, 0.2, 0.2, 0.0]},
        mean_choice={"KITTI-0000": 1, "KITTI-0001": 1},
        objective_all=[0.5, 0.7, 0.6, 0.65],
        in_sample=1,
        recommended=1,
        preset=3,
    )
    m = {"HOTA": 0.70, "MOTA": 0.8, "IDF1": 0.75, "IDSW": 4}
    cv.heldout["kitti-rrc-car"] = {**m, "HOTA": 0.68}
    cv.mean_heldout["kitti-rrc-car"] = {**m, "HOTA": 0.67}
    cv.insample["kitti-rrc-car"] = m
    cv.preset_metrics["kitti-rrc-car"] = {**m, "HOTA": 0.69}
    cv.per_sequence["kitti-rrc-car"] = {
        "0000": {"fold": "KITTI-0000", "choice": 1, "cv": 0.7, "in_sample": 0.7},
        "0001": {"fold": "KITTI-0001", "choice": 3, "cv": 0.6, "in_sample": 0.65},
    }
    summary = runner.RunSummary(
        benchmarks=[],
        skipped=[],
        trackers=["ours"],
        data_root="d",
        output_dir="o",
        command="sensemaking benchmark",
        started="now",
        crossval=[cv],
    )
    md = report.render_markdown(summary)
    head = md.index("## Headline: cross-validated")
    assert head < md.index("## How to read the tables")
    row = next(line for line in md.splitlines() if line.startswith("| kitti-rrc-car | 68.0"))
    assert "| 70.0 / 80.0 / 75.0 / 4 |" in row and "-2.0 **✗**" in row and "-5.0 … +0.0" in row
    params = report.render_parameters(summary)
    assert "## Cross-validation" in params and "| KITTI-0001 | 0.8 | 3 | 0.0 |" in params
    assert "`costs.resumes`" in params and "## Presets" in params
    console = report.console_summary(summary)
    assert console.index("cross-validated") < console.index("## Overview")
    data = report.summary_json(summary)
    assert data["crossval"][0]["choice"] == {"KITTI-0000": 1, "KITTI-0001": 3}

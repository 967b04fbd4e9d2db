"""Cross-validation of our parameters: folds are videos, a fold's choice never sees its video."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.benchmark import crossval, datasets
from sensemaking.detections import Detections


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
    cv = crossval.cross_validate([bench], tmp_path / "a", grid=grid, groups=True)
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
        [dataclasses.replace(bench, sequences=wrecked)],
        tmp_path / "b",
        grid=grid,
        groups=False,
        per_detector=False,
    )
    # rule calibrate: a fold's estimates never see its video, the other folds' do
    assert cv2.calibrated["KITTI-0002"] == cv.calibrated["KITTI-0002"]
    assert cv2.calibrated_all != cv.calibrated_all
    assert set(cv.calibrated) == set(cv.folds) and not cv2.calibrate_groups
    # one benchmark: per detector is the family's estimate, fold by fold
    assert cv.calibrated_own[bench.name] == cv.calibrated and not cv2.calibrated_own
    assert cv.calibrate_own_heldout[bench.name]["HOTA"] == cv.calibrate_heldout[bench.name]["HOTA"]
    assert set(cv.calibrate_groups) == set(crossval.CALIBRATE_GROUPS)
    assert cv2.per_sequence[bench.name]["0002"]["calibrate_cv"] == 0.0
    for fold in cv.folds:  # the held-out video's HOTA, as the per-sequence numbers give it
        (seq,) = [k for k, v in cv.per_sequence[bench.name].items() if v["fold"] == fold]
        assert cv.fold_hota["calibrate"][fold] == cv.per_sequence[bench.name][seq]["calibrate_cv"]
        assert cv.fold_hota["minimax"][fold] == cv.per_sequence[bench.name][seq]["cv"]
    assert 0.2 < cv.calibrate_heldout[bench.name]["HOTA"] < 1.0
    assert (tmp_path / "a" / "crossval" / bench.name / "calibrate" / "0004.txt").is_file()
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
    from conftest import load_benchmarks_script

    from sensemaking.benchmark import runner

    report = load_benchmarks_script("benchmark_report")

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
    cv.calibrate_heldout["kitti-rrc-car"] = {**m, "HOTA": 0.655}
    cv.calibrate_insample["kitti-rrc-car"] = {**m, "HOTA": 0.665}
    cv.calibrate_groups = {g: {"kitti-rrc-car": {**m, "HOTA": 0.6}} for g in ("thresholds",)}
    cv.calibrated_all = {"start_confidence": 0.75, "min_hits": 4}
    cv.fold_hota = {
        "minimax": {"KITTI-0000": 0.7, "KITTI-0001": 0.6},
        "calibrate": {"KITTI-0000": 0.69, "KITTI-0001": 0.62},
    }
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
    # calibrate beside the grid: its verdict by the stated rule (65.5 vs 68.0: worse)
    assert "| kitti-rrc-car | 68.0 / 80.0 / 75.0 / 4 | 65.5 / 80.0 / 75.0 / 4 |" in md
    assert "not worse on 1 of 2 folds: **worse**" in params
    assert "`start_confidence=0.75`, `min_hits=4`" in params
    assert "KITTI-0001 60.0 → 62.0" in params and "only thresholds" in params
    # where every value comes from: one row per parameter
    origins = params[params.index("## Where each value comes from") :]
    from sensemaking import settings

    for key in settings.PARAMETERS:
        assert f"| `{key}` |" in origins, key
    console = report.console_summary(summary)
    assert console.index("cross-validated") < console.index("## Overview")
    data = report.summary_json(summary)
    assert data["crossval"][0]["choice"] == {"KITTI-0000": 1, "KITTI-0001": 3}
    assert data["crossval"][0]["calibrate_verdict"]["as_good"] is False
    again = crossval.FamilyCV.from_json(json.loads(json.dumps(data["crossval"][0])))
    assert again.to_json() == cv.to_json()


def _verdict_cv(grid_folds: list[float], cal_folds: list[float], means: tuple[float, float]):
    folds = [f"V{k}" for k in range(len(grid_folds))]
    cv = crossval.FamilyCV(
        family="kitti", grid={}, points=[], benchmarks=["a", "b"], sequences={}, folds=folds
    )
    cv.heldout = {"a": {"HOTA": means[0]}, "b": {"HOTA": means[0]}}
    cv.calibrate_heldout = {"a": {"HOTA": means[1] - 0.01}, "b": {"HOTA": means[1] + 0.01}}
    cv.fold_hota = {
        "minimax": dict(zip(folds, grid_folds, strict=True)),
        "calibrate": dict(zip(folds, cal_folds, strict=True)),
    }
    return crossval.calibrate_verdict(cv)


def test_calibrate_verdict_is_the_stated_rule() -> None:
    # mean within 0.3 HOTA and not worse (by more than 0.1) on 2 of 3 folds: as good
    v = _verdict_cv([0.5, 0.6, 0.7], [0.5005, 0.6, 0.69], (0.6, 0.598))
    assert v["as_good"] and v["folds_not_worse"] == 2 and v["folds"] == 3
    assert v["mean_calibrate"] == pytest.approx(0.598)
    # the same folds, the mean 0.4 below: not as good
    assert not _verdict_cv([0.5, 0.6, 0.7], [0.5, 0.6, 0.69], (0.6, 0.596))["as_good"]
    # a better mean but worse on 2 of 3 folds: not as good (half is not most)
    v = _verdict_cv([0.5, 0.6, 0.7], [0.49, 0.6, 0.69], (0.6, 0.7))
    assert not v["as_good"] and v["folds_not_worse"] == 1
    assert not _verdict_cv([0.5, 0.6], [0.5, 0.5], (0.6, 0.6))["as_good"]


def test_every_parameter_has_an_origin() -> None:
    """Each parameter that is neither on the grid nor estimated by calibrate says where its value
    comes from (switches added later may fall back to the generic line)."""
    from sensemaking import settings

    assert set(crossval.ORIGINS) <= set(settings.PARAMETERS)
    grid_keys = {k for g in crossval.GRID.values() for k in g}
    for key, p in settings.PARAMETERS.items():
        if key in grid_keys or p.kind == "bool":
            continue
        assert crossval.ORIGINS.get(key), key
    assert set(crossval.calibrate_keys()) <= set(settings.PARAMETERS)
    assert {k for g in crossval.CALIBRATE_GROUPS.values() for k in g} == set(
        crossval.calibrate_keys()
    )

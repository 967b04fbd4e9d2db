"""benchmarks/make_presets.py: the presets written from a run's cross-validation."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from conftest import REPO

from sensemaking import settings

SCRIPT = REPO / "benchmarks" / "make_presets.py"
PRESETS = REPO / "src" / "sensemaking" / "presets"


def _script():
    spec = importlib.util.spec_from_file_location("make_presets", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _run(tmp_path: Path, as_good: bool) -> tuple[Path, dict]:
    presets = tmp_path / "presets"
    presets.mkdir()
    for f in ("kitti", "mot"):
        (presets / f"{f}.json").write_text((PRESETS / f"{f}.json").read_text())
    cv = {
        "family": "kitti",
        "folds": ["KITTI-0000", "KITTI-0001", "KITTI-0002"],
        "points": [
            {"start_confidence": 0.6, "min_hits": 2},
            {"start_confidence": 0.7, "min_hits": 3},
        ],
        "choice": {"KITTI-0000": 1, "KITTI-0001": 1, "KITTI-0002": 0},
        "recommended": 1,
        "calibrated_all": {"start_confidence": 0.75, "costs.appears": 300, "min_hits": 4},
        "calibrate_verdict": {
            "as_good": as_good,
            "mean_grid": 0.6,
            "mean_calibrate": 0.59,
            "folds_not_worse": 1,
            "folds": 3,
        },
    }
    run = {"started": "2026-11-25", "command": "sensemaking benchmark", "crossval": [cv]}
    js = tmp_path / "run.json"
    js.write_text(json.dumps(run))
    assert _script().main(["--json", str(js), "--presets", str(presets)]) == 0
    return presets / "kitti.json", json.loads((presets / "kitti.json").read_text())


def test_the_layout_of_the_shipped_presets_is_kept() -> None:
    dump = _script().dump
    for f in ("kitti", "mot"):
        text = (PRESETS / f"{f}.json").read_text()
        assert dump(json.loads(text)) == text


def test_grid_choice_when_calibrate_is_worse(tmp_path: Path) -> None:
    before = settings.preset_params("kitti")
    path, doc = _run(tmp_path, as_good=False)
    values = settings.load_params(path)
    assert values["start_confidence"] == 0.7 and values["min_hits"] == 3
    assert values.get("costs.appears") == before.get("costs.appears")  # calibrate's not used
    assert {k: v for k, v in values.items() if k not in ("start_confidence", "min_hits")} == {
        k: v for k, v in before.items() if k not in ("start_confidence", "min_hits")
    }
    assert "2 of 3 leave-one-video-out folds chose" in doc["source"]
    assert "cross-validated worse (59.00 against 60.00" in doc["source"]
    assert "image_size" in doc["source"].split("Kept from the earlier preset")[1]


def test_calibrate_values_when_as_good(tmp_path: Path) -> None:
    path, doc = _run(tmp_path, as_good=True)
    values = settings.load_params(path)
    assert values["start_confidence"] == 0.75 and values["min_hits"] == 4
    assert values["costs.appears"] == 300 and values["costs.resumes"] == 200
    assert "estimated by `sensemaking calibrate`" in doc["source"]
    assert list(doc["params"])[0] == "fps"  # key order kept, new keys appended

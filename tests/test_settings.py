"""Parameters as data: presets, the range table, typed --set, parameter files, their errors."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from sensemaking import settings
from sensemaking.cli import main
from sensemaking.io.mot import read_mot
from sensemaking.settings import ParameterError
from sensemaking.synthetic import crossing_scene
from sensemaking.tracker import TrackerConfig

REPO = Path(__file__).resolve().parents[1]


def test_presets_are_data_and_match_the_family_names() -> None:
    kitti = TrackerConfig.for_dataset("kitti")
    assert (kitti.min_hits, kitti.start_confidence, kitti.costs.resumes) == (3, 0.7, 200)
    assert kitti.kalman.velocity_std == 0.1 and kitti.image_size == (1242, 375)
    mot = TrackerConfig.for_dataset("motchallenge")
    assert mot == TrackerConfig.for_dataset("mot") == TrackerConfig.for_dataset("MOT17")
    assert mot.kalman.measurement_std == 1 / 17 and mot.costs.leaves == 300 and mot.fps == 30.0
    assert TrackerConfig.for_dataset("kitti", fps=12.5).fps == 12.5
    for family in settings.FAMILIES:
        assert settings.preset_source(family)  # each preset says where its values came from
        assert set(settings.preset_params(family)) <= set(settings.PARAMETERS)
    with pytest.raises(ValueError, match="unknown dataset family 'nuscenes'"):
        TrackerConfig.for_dataset("nuscenes")


def test_every_parameter_has_a_row_and_every_row_a_parameter() -> None:
    assert set(settings.params_of(TrackerConfig())) == set(settings.PARAMETERS)
    table = settings.parameters_table()
    for key, p in settings.PARAMETERS.items():
        assert f"| `{key}` | {p.unit} |" in table
    assert "perfect IoU match" in table and "frames / s" in table
    # every parameter has a meaning (a field comment on a wrapped line was once lost)
    for row in table.splitlines()[2:]:
        assert row.split("|")[-2].strip(), row


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"min_hits": 1.5}, "min_hits must be an integer"),
        ({"min_hits": 0}, "min_hits must be in"),
        ({"max_hidden_s": -1}, "max_hidden_s must be in"),
        ({"fps": 0}, "fps must be in"),
        ({"fps": float("nan")}, "fps must be a finite number"),
        ({"abduction": "false"}, "abduction must be true or false"),
        ({"iou_assign": 1.5}, "iou_assign must be in"),
        ({"max_solve_ms": -1.0}, "max_solve_ms must be in"),
        ({"keep_cover": 0.9}, "keep_cover (0.9) must not exceed hide_cover"),
        ({"image_size": (0, 375)}, "image_size must be in"),
        ({"start_confidence": float("inf")}, "start_confidence must be a finite number"),
    ],
)
def test_config_validation_names_the_parameter(changes: dict, message: str) -> None:
    with pytest.raises(ParameterError) as err:
        TrackerConfig(**changes)
    assert message in str(err.value)
    assert isinstance(err.value, ValueError)


def test_nested_values_are_validated_through_the_config() -> None:
    costs = dataclasses.replace(TrackerConfig().costs)
    object.__setattr__(costs, "resumes", 2.5)  # bypass the cost class's own check
    with pytest.raises(ParameterError, match="costs.resumes must be an integer"):
        TrackerConfig(costs=costs)


@pytest.mark.parametrize(
    "key, text, value",
    [
        ("abduction", "False", False),
        ("abduction", "false", False),
        ("abduction", "TRUE", True),
        ("min_hits", "2", 2),
        ("max_hidden_s", "1.5", 1.5),
        ("confirm_confidence", "null", None),
        ("image_size", "640x480", (640, 480)),
        ("costs.resumes", "200", 200),
        ("kalman.velocity_std", "0.1", 0.1),
        ("max_solve_ms", "none", None),
    ],
)
def test_set_values_are_typed(key: str, text: str, value) -> None:
    assert settings.parse_value(key, text) == value


@pytest.mark.parametrize(
    "key, text, message",
    [
        ("min_hits", "1.5", "min_hits must be an integer"),
        ("max_hidden_s", "-1", "max_hidden_s must be in [0, 3600]"),
        ("fps", "0", "fps must be in [0.01, 1000]"),
        ("fps", "nan", "fps must be a finite number"),
        ("abduction", "maybe", "abduction must be true or false"),
        ("max_hidden_s", "abc", "max_hidden_s must be a number"),
        ("costs.resume", "1", "unknown parameter 'costs.resume' (did you mean 'costs.resumes'?)"),
        ("kalman.xxx", "1", "unknown parameter 'kalman.xxx'"),
        ("min_hits", "null", "min_hits must be an integer"),
    ],
)
def test_bad_set_values_are_errors(key: str, text: str, message: str) -> None:
    with pytest.raises(ParameterError) as err:
        settings.parse_value(key, text)
    assert message in str(err.value)


def test_layers_preset_file_facts_then_set(tmp_path: Path) -> None:
    path = tmp_path / "p.json"
    path.write_text(
        json.dumps(
            {
                "format": settings.FORMAT,
                "source": "test",
                "params": {"min_hits": 1, "costs": {"appears": 300}, "kalman.velocity_std": 0.05},
            }
        )
    )
    config = settings.load_config(
        path, "kitti", {"fps": 25.0}, ["costs.resumes=150", "min_hits=4"]
    )
    assert config.start_confidence == 0.7  # from the kitti preset
    assert config.costs.appears == 300 and config.kalman.velocity_std == 0.05  # from the file
    assert config.fps == 25.0  # a fact of the input
    assert config.costs.resumes == 150 and config.min_hits == 4  # --set last
    # base in the file wins over the caller's family
    path.write_text(json.dumps({"base": "mot", "params": {}}))
    assert settings.load_config(path, "kitti") == TrackerConfig.for_dataset("mot")
    path.write_text(json.dumps({"base": "defaults", "params": {"min_hits": 2}}))
    assert settings.load_config(path, "kitti") == TrackerConfig(min_hits=2)


def test_toml_files_are_read(tmp_path: Path) -> None:
    path = tmp_path / "p.toml"
    path.write_text('base = "kitti"\n[params]\nmin_hits = 2\n[params.costs]\nresumes = 120\n')
    config = settings.load_config(path)
    assert (config.min_hits, config.costs.resumes, config.start_confidence) == (2, 120, 0.7)


@pytest.mark.parametrize(
    "doc, message",
    [
        ({"params": {"min_hit": 3}}, "unknown parameter 'min_hit'"),
        ({"params": {"costs": {"resume": 3}}}, "unknown parameter 'costs.resume'"),
        ({"params": {"min_hits": 1.5}}, "params.min_hits must be an integer"),
        ({"params": {"max_hidden_s": "3s"}}, "params.max_hidden_s must be a finite number (s,"),
        ({"params": {"abduction": "false"}}, "params.abduction must be true or false"),
        ({"params": {"fps": 0}}, "params.fps must be in [0.01, 1000]"),
        ({"params": {"costs": 5}}, "costs: expected a table"),
        ({"parms": {}}, "unknown key 'parms'"),
        ({"format": "other/2", "params": {}}, "format 'other/2'"),
        ({"base": "nuscenes", "params": {}}, "base 'nuscenes' is not kitti, mot or defaults"),
        ([1, 2], "must hold an object"),
    ],
)
def test_bad_parameter_files_name_the_file_and_key(tmp_path: Path, doc, message: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ParameterError) as err:
        settings.load_params(path)
    text = str(err.value)
    assert text.startswith(f"{path}: ") and message in text and "\n" not in text


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(ParameterError, match="parameter file not found"):
        settings.load_params(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"params": {"min_hits": 3,}\n}')
    with pytest.raises(ParameterError, match=r"bad.json:1: not valid JSON"):
        settings.load_params(bad)
    bad_toml = tmp_path / "bad.toml"
    bad_toml.write_text("[params\n")
    with pytest.raises(ParameterError, match="not valid TOML"):
        settings.load_params(bad_toml)


def test_write_params_round_trips(tmp_path: Path) -> None:
    params = {
        "min_hits": 2,
        "start_confidence": 0.55,
        "confirm_confidence": None,
        "costs.appears": 321,
        "kalman.velocity_std": 1 / 12,
        "image_size": (640, 480),
    }
    path = settings.write_params(tmp_path / "out.json", params, source="a test", base="kitti")
    assert settings.load_params(path) == params
    config = settings.load_config(path)
    assert config.costs.appears == 321 and config.kalman.velocity_std == 1 / 12
    assert config.iou_assign == 0.2  # the kitti base
    with pytest.raises(ParameterError, match="min_hits must be in"):
        settings.write_params(tmp_path / "never.json", {"min_hits": 0}, source="x")
    assert not (tmp_path / "never.json").exists()


# -- the CLI -----------------------------------------------------------------------------------
@pytest.fixture()
def det_file(tmp_path: Path) -> Path:
    seq = tmp_path / "CROSS-01"
    (seq / "det").mkdir(parents=True)
    scene = crossing_scene(0, gap=12, far_speed=8.0)
    d = scene.detections
    order = np.argsort(d.frame, kind="stable")
    lines = [
        f"{d.frame[i] + 1},-1,{x:.2f},{y:.2f},{w:.2f},{h:.2f},{d.confidence[i]:.3f},-1,-1,-1"
        for i, (x, y, w, h) in zip(order, d.xywh[order], strict=False)
    ]
    (seq / "det" / "det.txt").write_text("\n".join(lines) + "\n")
    (seq / "seqinfo.ini").write_text(
        f"[Sequence]\nname=CROSS-01\nframeRate=10\nseqLength={scene.n_frames}\n"
        "imWidth=1242\nimHeight=375\n"
    )
    return seq / "det" / "det.txt"


def _track(det: Path, out: Path, *extra: str) -> int:
    return main(
        ["-q", "track", "--detections", str(det), "--format", "mot", "--output", str(out), *extra]
    )


def test_set_abduction_false_is_the_ablation(tmp_path: Path, det_file: Path) -> None:
    outs = {}
    for name, extra in {
        "flag": ["--no-abduction"],
        "False": ["--set", "abduction=False"],
        "false": ["--set", "abduction=false"],
        "on": [],
    }.items():
        out = tmp_path / f"{name}.txt"
        assert _track(det_file, out, *extra) == 0
        outs[name] = out.read_text()
    assert outs["flag"] == outs["False"] == outs["false"]
    assert outs["on"] != outs["flag"]  # the crossing scene needs abduction to keep its ids


def test_params_file_reaches_the_tracker(tmp_path: Path, det_file: Path) -> None:
    out_default, out_file = tmp_path / "a.txt", tmp_path / "b.txt"
    assert _track(det_file, out_default) == 0
    params = settings.write_params(tmp_path / "p.json", {"max_hidden_s": 0.5}, source="test")
    assert _track(det_file, out_file, "--params", str(params)) == 0
    # a 12-frame occlusion at 10 fps outlasts 0.5 s: the hidden track is lost and comes back new
    ids = {
        p: len(np.unique(read_mot(p, kind="results").tracker_id)) for p in (out_default, out_file)
    }
    assert ids[out_default] == 2 and ids[out_file] == 3
    # --set overrides the file
    out_set = tmp_path / "c.txt"
    assert _track(det_file, out_set, "--params", str(params), "--set", "max_hidden_s=3") == 0
    assert out_set.read_text() == out_default.read_text()


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--set", "min_hits=1.5"], "--set min_hits must be an integer"),
        (["--set", "max_hidden_s=-1"], "--set max_hidden_s must be in [0, 3600]"),
        (["--set", "fps=0"], "--set fps must be in [0.01, 1000]"),
        (["--set", "max_hidden_s=abc"], "--set max_hidden_s must be a number"),
        (["--set", "costs.resumes=2.5"], "--set costs.resumes must be an integer"),
        (["--set", "nonsense"], "expected KEY=VALUE"),
        # the CLI's own option checks come first, with the option's name
        (["--fps", "0"], "--fps must be a frame rate in [0.01, 1000]"),
        (["--fps", "nan"], "--fps must be a frame rate in [0.01, 1000]"),
        (["--max-solve-ms", "-1"], "--max-solve-ms must be a positive number of milliseconds"),
    ],
)
def test_bad_cli_parameters_exit_2_with_one_line(
    tmp_path: Path, det_file: Path, capsys, extra, message
) -> None:
    out = tmp_path / "r.txt"
    assert _track(det_file, out, *extra) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()


def test_bad_params_file_on_the_cli(tmp_path: Path, det_file: Path, capsys) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"params": {"costs": {"hide": 10}}}))
    out = tmp_path / "r.txt"
    assert _track(det_file, out, "--params", str(bad)) == 2
    err = capsys.readouterr().err
    assert f"{bad}: params: unknown parameter 'costs.hide' (did you mean 'costs.hides'?)" in err
    assert not out.exists()


def test_parameters_doc_lists_every_parameter() -> None:
    doc = (REPO / "docs" / "PARAMETERS.md").read_text(encoding="utf-8")
    for key in settings.PARAMETERS:
        assert f"`{key}`" in doc, key


def test_a_principal_point_half_set_is_a_one_line_error(
    tmp_path: Path, det_file: Path, capsys
) -> None:
    out = tmp_path / "r.txt"
    assert _track(det_file, out, "--set", "kalman.perspective_x=600") == 2
    assert "--set: kalman.perspective_x and kalman.perspective_y are set together" in (
        capsys.readouterr().err
    )
    params = tmp_path / "p.json"
    params.write_text(json.dumps({"params": {"kalman": {"perspective_y": 170}}}))
    assert _track(det_file, out, "--params", str(params)) == 2
    err = capsys.readouterr().err
    assert f"{params}: kalman.perspective_x and kalman.perspective_y" in err
    assert not out.exists()

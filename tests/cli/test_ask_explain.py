"""``sensemaking ask`` and ``sensemaking explain``."""

from __future__ import annotations

import json

import pytest
from test_scene_helpers import build_scene, cyclist_behind_turning_car

from sensemaking.cli import main


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "scene.json"
    build_scene(cyclist_behind_turning_car()).save(path)
    return path


def test_ask_named_question(scene_file, capsys):
    assert main(["ask", str(scene_file), "reappeared", "1"]) == 0
    assert capsys.readouterr().out == (
        "track 1 (cyclist) reappeared at frame 34 from behind track 2 (car), "
        "unseen since frame 21: 13 frames (1.3 s)\n"
    )


def test_ask_asp_query_and_json(scene_file, capsys):
    assert main(["ask", str(scene_file), "q(T) :- occurs_at(hides_behind(T,_),_)."]) == 0
    assert capsys.readouterr().out == "q(1)\n"
    assert main(["ask", "--json", str(scene_file), "in-front", "25"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["atoms"] == ["in_front(25,2,290)", "in_front(25,1,254)"]


def test_ask_query_from_file_and_unsat_exit_status(scene_file, tmp_path, capsys):
    q = tmp_path / "q.lp"
    q.write_text("% which tracks were ever hidden?\nh(T) :- state(T,_,hidden).\n#show h/1.\n")
    assert main(["ask", str(scene_file), str(q)]) == 0
    assert capsys.readouterr().out == "h(1)\n"
    assert main(["ask", str(scene_file), ":- track(1,cyclist)."]) == 1
    assert "UNSATISFIABLE" in capsys.readouterr().out


def test_ask_malformed_query_is_a_clean_error_with_position(scene_file, capsys):
    assert main(["ask", str(scene_file), "q(T) :- track(T,car"]) == 2
    err = capsys.readouterr().err
    assert (
        err.startswith("sensemaking ask: error: invalid query: query:") and "syntax error" in err
    )
    assert "Traceback" not in err


def test_ask_unknown_track_and_bad_files(scene_file, tmp_path, capsys):
    assert main(["ask", str(scene_file), "why-ended", "42"]) == 0
    assert capsys.readouterr().out == "track 42 does not appear in this scene (tracks: 1, 2)\n"
    assert main(["ask", str(tmp_path / "none.json"), "hidden"]) == 2
    assert "scene file not found" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2")
    assert main(["ask", str(bad), "hidden"]) == 2
    assert "bad.json:1: not valid JSON" in capsys.readouterr().err
    assert main(["ask", str(scene_file), "reappeared", "one"]) == 2
    assert "usage: reappeared TRACK" in capsys.readouterr().err


def test_explain(scene_file, capsys):
    assert main(["explain", str(scene_file)]) == 0
    out = capsys.readouterr().out
    paragraphs = out.strip().split("\n\n")
    assert len(paragraphs) == 2 and paragraphs[0].startswith(
        "Track 1 (cyclist) is in view from the first frame"
    )
    assert main(["explain", str(scene_file), "--track", "2", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["2"][2] == "At frame 21 it hides track 1 (cyclist) from view."
    assert main(["explain", str(scene_file), "--track", "7"]) == 1
    assert capsys.readouterr().out == "track 7 does not appear in this scene (tracks: 1, 2)\n"

"""``sensemaking evaluate``: files and folders in, table out, JSON written atomically."""

from __future__ import annotations

import json

import pytest

from sensemaking.cli import main

KITTI_ROW = "{f} {i} {t} 0 0 0 {x1} {y1} {x2} {y2} 1 1 1 1 1 1 0"


@pytest.fixture
def mot(tmp_path):
    for name in ("A", "B"):
        (tmp_path / "gt" / name / "gt").mkdir(parents=True)
        (tmp_path / "gt" / name / "gt" / "gt.txt").write_text(
            "1,1,0,0,10,10,1,1,1\n2,1,0,0,10,10,1,1,1\n3,1,0,0,10,10,1,1,1\n"
        )
        (tmp_path / "gt" / name / "seqinfo.ini").write_text(
            f"[Sequence]\nname={name}\nseqLength=3\nimWidth=640\nimHeight=480\nframeRate=30\n"
        )
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "A.txt").write_text("1,3,0,0,10,10,1,-1,-1,-1\n3,4,0,0,10,10,1,-1,-1,-1\n")
    (tmp_path / "res" / "B.txt").write_text(
        "1,3,0,0,10,10,1,-1,-1,-1\n2,3,0,0,10,10,1,-1,-1,-1\n3,3,0,0,10,10,1,-1,-1,-1\n"
    )
    return tmp_path


def test_evaluate_mot_folder_table_and_json(mot, capsys):
    out = mot / "out" / "scores.json"
    rc = main(
        ["evaluate", "--gt", str(mot / "gt"), "--results", str(mot / "res"), "--json", str(out)]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "mot17 / pedestrian" in text and "idsw_mode: trackeval" in text
    scores, occlusion = text.split("\n\n", 1)  # the score table, then identity through occlusion
    assert [line.split()[0] for line in scores.splitlines()[2:] if not line.startswith("-")] == [
        "A",
        "B",
        "COMBINED",
    ]
    assert occlusion.startswith("Identity through occlusion (mot17 / pedestrian)")
    data = json.loads(out.read_text())
    assert data["idsw_mode"] == "trackeval" and data["benchmark"] == "mot17"
    assert data["occlusion"]["pedestrian"]["pooled"]["episodes"] == 0  # nobody is hidden
    a = data["classes"]["pedestrian"]["sequences"]["A"]
    assert (a["CLR_TP"], a["CLR_FN"], a["IDSW"]) == (2, 1, 1)
    assert a["MOTA"] == pytest.approx(1 / 3)
    assert list(out.parent.iterdir()) == [out]  # no temporary file left behind


def test_evaluate_legacy_mode_and_single_files(mot, capsys):
    out = mot / "legacy.json"
    rc = main(
        [
            "evaluate",
            "--gt",
            str(mot / "gt" / "A" / "gt" / "gt.txt"),
            "--results",
            str(mot / "res" / "A.txt"),
            "--benchmark",
            "mot17",
            "--idsw-mode",
            "kitti_legacy",
            "--json",
            str(out),
        ]
    )
    assert rc == 0
    assert "idsw_mode: kitti_legacy" in capsys.readouterr().out
    data = json.loads(out.read_text())
    a = data["classes"]["pedestrian"]["sequences"]["A"]
    assert data["idsw_mode"] == "kitti_legacy" and a["IDSW"] == 0  # not tracked in frame 2


def test_evaluate_errors(mot, capsys):
    (mot / "res" / "B.txt").unlink()
    rc = main(["evaluate", "--gt", str(mot / "gt"), "--results", str(mot / "res")])
    assert rc == 2
    assert "no results for 1 sequence(s): B.txt" in capsys.readouterr().err
    rc = main(
        ["evaluate", "--gt", str(mot / "gt"), "--results", str(mot / "res"), "--missing-as-empty"]
    )
    assert rc == 0
    capsys.readouterr()

    seqmap = mot / "seqmap.txt"
    seqmap.write_text("name\nA\nZ\n")
    rc = main(
        [
            "evaluate",
            "--gt",
            str(mot / "gt"),
            "--results",
            str(mot / "res"),
            "--seqmap",
            str(seqmap),
        ]
    )
    assert rc == 2
    assert f"{seqmap}:3: unknown sequence 'Z'" in capsys.readouterr().err

    (mot / "res" / "A.txt").write_text("1,3,0,0,10,10,1,-1,-1,-1\n4,3,0,0,10,10,1,-1,-1,-1\n")
    rc = main(
        ["evaluate", "--gt", str(mot / "gt"), "--results", str(mot / "res"), "--missing-as-empty"]
    )
    assert rc == 2
    assert (
        "A.txt:2: frame 4 is outside the sequence (frames 1..3, 3 frames)"
        in capsys.readouterr().err
    )

    for bad in (
        ["--format", "kitti", "--benchmark", "mot17"],
        ["--benchmark", "mot17", "--classes", "car"],
    ):
        with pytest.raises(SystemExit) as exc:
            main(["evaluate", "--gt", str(mot / "gt"), "--results", str(mot / "res"), *bad])
        assert exc.value.code == 2
    capsys.readouterr()


def test_evaluate_kitti_folder(tmp_path, capsys):
    (tmp_path / "training" / "label_02").mkdir(parents=True)
    rows = [KITTI_ROW.format(f=f, i=0, t="Car", x1=0, y1=0, x2=50, y2=50) for f in range(3)]
    rows += [
        KITTI_ROW.format(f=f, i=1, t="Pedestrian", x1=100, y1=0, x2=130, y2=80) for f in range(3)
    ]
    (tmp_path / "training" / "label_02" / "0003.txt").write_text("\n".join(rows) + "\n")
    (tmp_path / "training" / "seqinfo.csv").write_text(
        "seq,num_frames,im_width,im_height,frame_rate\n0003,3,1242,375,10\n"
    )
    (tmp_path / "res").mkdir()
    res = [
        KITTI_ROW.format(f=f, i=7 if f < 2 else 8, t="Car", x1=0, y1=0, x2=50, y2=50) + " 0.9"
        for f in range(3)
    ]
    (tmp_path / "res" / "0003.txt").write_text("\n".join(res) + "\n")
    out = tmp_path / "k.json"
    rc = main(
        [
            "evaluate",
            "--gt",
            str(tmp_path / "training"),
            "--results",
            str(tmp_path / "res"),
            "--classes",
            "car,pedestrian",
            "--json",
            str(out),
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "kitti / car" in text and "kitti / pedestrian" in text
    data = json.loads(out.read_text())
    car = data["classes"]["car"]["combined"]
    assert (car["CLR_TP"], car["IDSW"]) == (3, 1)
    assert data["classes"]["pedestrian"]["combined"]["CLR_FN"] == 3

"""benchmarks/subsampled_mot.py writes MOT17 sequences at a lower frame rate, one folder per
offset, laid out like the shared data."""

from __future__ import annotations

from pathlib import Path

from conftest import load_benchmarks_script


def _sequence(root: Path, name: str, fps: int, frames: int) -> None:
    seq = root / "mot17" / name
    (seq / "det").mkdir(parents=True)
    (seq / "gt").mkdir()
    (seq / "det" / "det.txt").write_text(
        "".join(f"{f},-1,{f}.0,5.0,10.0,20.0,0.9,-1,-1,-1\n" for f in range(1, frames + 1))
    )
    (seq / "gt" / "gt.txt").write_text(
        "".join(f"{f},1,{f},5,10,20,1,1,1.0\n" for f in range(1, frames + 1))
    )
    (seq / "seqinfo.ini").write_text(
        f"[Sequence]\nname={name}\nimDir=img1\nframeRate={fps}\nseqLength={frames}\n"
        "imWidth=640\nimHeight=480\nimExt=.jpg\n"
    )


def test_every_third_frame_per_offset_renumbered(tmp_path: Path, capsys) -> None:
    script = load_benchmarks_script("subsampled_mot")
    data = tmp_path / "data"
    _sequence(data, "MOT17-02-YOLOX-half", 30, 10)
    _sequence(data, "MOT17-05-YOLOX-half", 14, 10)  # not a multiple of 10 fps: skipped
    out = tmp_path / "out"
    assert script.main([str(out), "--data", str(data), "--fps", "10"]) == 0
    assert "skipped MOT17-05-YOLOX-half" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["o1", "o2", "o3"]
    assert not (out / "o1" / "mot17" / "MOT17-05-YOLOX-half").exists()
    for offset, kept in ((1, [1, 4, 7, 10]), (2, [2, 5, 8]), (3, [3, 6, 9])):
        seq = out / f"o{offset}" / "mot17" / "MOT17-02-YOLOX-half"
        det = [line.split(",") for line in (seq / "det" / "det.txt").read_text().splitlines()]
        # renumbered from 1, each row the original frame's (its x is the old frame number)
        assert [int(r[0]) for r in det] == list(range(1, len(kept) + 1))
        assert [float(r[2]) for r in det] == [float(f) for f in kept]
        gt = (seq / "gt" / "gt.txt").read_text().splitlines()
        assert [int(r.split(",")[2]) for r in gt] == kept
        info = (seq / "seqinfo.ini").read_text()
        assert "frameRate=10\n" in info and f"seqLength={len(kept)}\n" in info


def test_no_mot17_folder_is_an_error(tmp_path: Path, capsys) -> None:
    script = load_benchmarks_script("subsampled_mot")
    assert script.main([str(tmp_path / "out"), "--data", str(tmp_path)]) == 2
    assert "no such folder" in capsys.readouterr().err

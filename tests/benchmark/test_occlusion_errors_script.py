"""benchmarks/occlusion_errors.py on a data folder holding part of the benchmarks."""

from __future__ import annotations

from pathlib import Path

from conftest import load_benchmarks_script


def test_sequences_absent_from_the_data_are_skipped_with_a_notice(tmp_path: Path, capsys) -> None:
    script = load_benchmarks_script("occlusion_errors")
    seq = tmp_path / "mot17" / "MOT17-09-YOLOX-half"
    for sub in ("det/det.txt", "gt/gt.txt"):
        (seq / sub).parent.mkdir(parents=True, exist_ok=True)
        (seq / sub).write_text("")
    found = list(script.items(["mot17"], tmp_path))
    assert [i.seq for i in found] == ["MOT17-09-YOLOX-half"]
    err = capsys.readouterr().err
    assert "skipped mot17 MOT17-02-YOLOX-half" in err and "MOT17-09" not in err
    # without a data folder every sequence of the benchmark is listed, as before
    assert len(list(script.items(["mot17"]))) == len(script.MOT_SEQS)

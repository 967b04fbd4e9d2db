"""Integration: the peers on one real KITTI sequence.

Needs ../shared/data and the 'benchmark' extra.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from conftest import SHARED_DATA

from sensemaking.benchmark import datasets, runner

pytestmark = [
    pytest.mark.integration,
    pytest.mark.skipif(not (SHARED_DATA / "kitti").is_dir(), reason="needs ../shared/data/kitti"),
    pytest.mark.skipif(
        importlib.util.find_spec("trackers") is None, reason="needs the 'benchmark' extra"
    ),
]


def test_peers_on_kitti_0000_car_rrc(tmp_path: Path) -> None:
    found = datasets.discover(SHARED_DATA, only=["kitti-rrc-car"])
    ((spec, sources),) = found.found
    bench = datasets.load_benchmark(spec, [s for s in sources if s.name == "0000"])
    assert [s.name for s in bench.sequences] == ["0000"] and bench.n_frames == 154
    result = runner.run_benchmark(bench, ["sort", "bytetrack", "ocsort"], tmp_path)
    for name in ("sort", "bytetrack", "ocsort"):
        variants = {r.variant: r for r in result.runs[name]}
        assert set(variants) == {"default", "prefilter"} or set(variants) == {"default"}
        for run_ in variants.values():
            assert run_.error is None
            m = run_.metrics
            assert 0.5 < m["MOTA"] <= 1.0, (name, run_.variant, m["MOTA"])
            assert 0.5 < m["HOTA"] <= 1.0 and 0.5 < m["IDF1"] <= 1.0
            assert run_.legacy is not None and run_.legacy["IDSW"] >= 0
            assert (tmp_path / "kitti-rrc-car").is_dir() and run_.ms_per_frame < 50

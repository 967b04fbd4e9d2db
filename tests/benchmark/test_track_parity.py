"""`sensemaking track` as a user runs it gives the benchmark runner's number (../shared/data).

One loading path: a PointRCNN file (15 columns) is mapped from logits to probabilities by
``read_detections`` for both; the parameters are the family preset for both.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.benchmark import datasets, runner
from sensemaking.cli import main

pytestmark = [
    pytest.mark.integration,
    pytest.mark.slow,  # whole sequences through `track` and the runner
    pytest.mark.skipif(not SHARED_DATA.is_dir(), reason="needs ../shared/data"),
]


@pytest.mark.parametrize(
    "bench_name, sequence, fmt, gt_arg, extra",
    [
        (
            "kitti-pointrcnn-car",
            "0001",
            "kitti",
            "kitti/training/label_02/0001.txt",
            ["--benchmark", "kitti", "--classes", "car"],
        ),
        (
            "kitti-rrc-pedestrian",
            "0004",
            "kitti",
            "kitti/training/label_02/0004.txt",
            ["--benchmark", "kitti", "--classes", "pedestrian"],
        ),
        ("mot15", "TUD-Campus", "mot", "mot15/TUD-Campus/gt/gt.txt", ["--benchmark", "mot15"]),
        (
            "mot17-yolox-halfval",
            "MOT17-05-YOLOX-half",
            "mot",
            "mot17/MOT17-05-YOLOX-half/gt/gt.txt",
            ["--benchmark", "mot17"],
        ),
    ],
)
def test_track_then_evaluate_equals_the_runner(
    tmp_path: Path, bench_name: str, sequence: str, fmt: str, gt_arg: str, extra: list[str]
) -> None:
    found = datasets.discover(SHARED_DATA, only=[bench_name])
    ((spec, sources),) = found.found
    bench = datasets.load_benchmark(spec, [s for s in sources if s.name == sequence])
    result = runner.run_benchmark(bench, ["ours"], tmp_path / "runner")
    expected = next(r for r in result.runs["ours"] if r.variant == "visible").per_sequence[
        sequence
    ]

    seq = bench.sequences[0]
    if spec.logit_scores:  # the file holds logits; every tracker sees probabilities
        raw = np.loadtxt(seq.det_path, delimiter=",", usecols=6, ndmin=1)
        assert (raw < 0).any()
        np.testing.assert_allclose(
            np.sort(seq.detections.confidence), np.sort(1 / (1 + np.exp(-raw)))
        )
    out = tmp_path / "track" / f"{sequence}.txt"
    args = [
        "-q",
        "track",
        "--detections",
        str(seq.det_path),
        "--format",
        fmt,
        "--output",
        str(out),
    ]
    if fmt == "kitti" and spec.detector == "rrc":
        args += ["--class", str(spec.class_name)]
    assert main(args) == 0
    scores = tmp_path / "scores.json"
    assert (
        main(
            [
                "-q",
                "evaluate",
                "--gt",
                str(SHARED_DATA / gt_arg),
                "--results",
                str(out),
                "--format",
                fmt,
                "--json",
                str(scores),
                *extra,
            ]
        )
        == 0
    )
    got = _find_hota(json.loads(scores.read_text()), sequence)
    assert got is not None
    assert got == pytest.approx(expected["HOTA"], abs=1e-12)
    assert 0.2 < got < 1.0


def _find_hota(doc, sequence: str) -> float | None:
    """The HOTA of ``sequence`` anywhere in the evaluate verb's JSON."""
    if isinstance(doc, dict):
        if sequence in doc and isinstance(doc[sequence], dict) and "HOTA" in doc[sequence]:
            return float(doc[sequence]["HOTA"])
        for v in doc.values():
            found = _find_hota(v, sequence)
            if found is not None:
                return found
    if isinstance(doc, list):
        for v in doc:
            found = _find_hota(v, sequence)
            if found is not None:
                return found
    return None

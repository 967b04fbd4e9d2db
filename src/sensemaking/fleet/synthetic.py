"""A synthetic fleet: many short sequences with ground truth, written as MOTChallenge files
plus a manifest, for scale tests and benchmarks (``benchmarks/fleet_scale.py``)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

__all__ = ["write_synthetic_fleet", "FLEET_CLASSES"]

#: the class of sequence i is FLEET_CLASSES[i % 3]
FLEET_CLASSES = ("car", "pedestrian", "cyclist")


def write_synthetic_fleet(
    folder: str | Path,
    n_sequences: int,
    n_frames: int = 40,
    n_tracks: int = 4,
    seed: int = 0,
    dataset: str = "synthetic",
) -> Path:
    """Write ``n_sequences`` rendered scenes (:func:`sensemaking.synthetic.make_scene`, KITTI-like
    1242x375 px at 10 fps, occlusions, 5 % missed detections, a few false positives) as
    ``det/NNNNNN.txt`` and ``gt/NNNNNN.txt`` (MOT15 layout, frames from 1) and a
    ``manifest.csv`` listing them. Returns the manifest's path.
    """
    from sensemaking.classes import CLASS_IDS
    from sensemaking.io.mot import write_mot
    from sensemaking.synthetic import make_scene

    root = Path(folder)
    (root / "det").mkdir(parents=True, exist_ok=True)
    (root / "gt").mkdir(parents=True, exist_ok=True)
    rows = []
    for i in range(n_sequences):
        cls = FLEET_CLASSES[i % len(FLEET_CLASSES)]
        scene = make_scene(
            n_tracks,
            n_frames=n_frames,
            overlap=0.5,
            miss_rate=0.05,
            false_positive_rate=0.05,
            classes=(CLASS_IDS[cls],),
            seed=seed + i,
        )
        name = f"{i:06d}"
        det = scene.detections
        assert det.frame is not None  # set by __post_init__
        write_mot(root / "det" / f"{name}.txt", det.with_(frame=det.frame + 1))
        gt = scene.ground_truth
        assert gt.frame is not None  # set by __post_init__
        write_mot(
            root / "gt" / f"{name}.txt", gt.with_(frame=gt.frame + 1, confidence=np.ones(len(gt)))
        )
        rows.append(
            {
                "dataset": dataset,
                "sequence": name,
                "path": f"det/{name}.txt",
                "format": "mot",
                "class": cls,
                "fps": scene.fps,
                "width": scene.width,
                "height": scene.height,
                "frames": n_frames,
                "gt": f"gt/{name}.txt",
                "rules": "mot15",
            }
        )
    manifest = root / "manifest.csv"
    with open(manifest, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else ["path", "format"])
        w.writeheader()
        w.writerows(rows)
    return manifest

"""Peak memory of reading a scene file: ``Scene.load`` (a track at a time) against reading the
whole text with ``json.loads`` and then ``Scene.from_json`` (what it did before), as ratios to
the file's size.

The scene is synthetic (``--tracks`` tracks live over ``--frames`` frames, random boxes and
states, an event every few frames), written by ``Scene.save``; each reading runs in its own
process, which reports its peak resident memory (Linux: ``/proc/self/status``). Prints MB, the
ratio to the file's size above the memory of a process that only imports the package, and the
wall time.

    python benchmarks/scene_load.py [--frames 30000] [--tracks 22] [--keep scene.json]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

_READ = {
    "import only": "import sensemaking.scene",
    "json.loads + from_json": (
        "import json; from sensemaking.scene import Scene; "
        "Scene.from_json(json.loads(open(P, encoding='utf-8').read()), P)"
    ),
    "Scene.load": "from sensemaking.scene import Scene; Scene.load(P)",
}


def write_scene(path: Path, n_frames: int, n_tracks: int, seed: int = 0) -> None:
    """A synthetic scene of ``n_tracks`` tracks over frames 0..n_frames-1, saved to ``path``."""
    from sensemaking.results import Event
    from sensemaking.scene import Scene, Track

    rng = np.random.default_rng(seed)
    tracks = {}
    for k in range(1, n_tracks + 1):
        first = int(rng.integers(0, n_frames // 10))
        frames = np.arange(first, n_frames, dtype=np.int64)
        n = frames.size
        xy = rng.uniform(0, 1800, (n, 2))
        wh = rng.uniform(20, 200, (n, 2))
        state = rng.choice(3, n, p=[0.95, 0.03, 0.02]).astype(np.int8)
        tracks[k] = Track(
            id=k,
            class_id=3,
            frames=frames,
            xyxy=np.round(np.hstack([xy, xy + wh]), 2),
            confidence=np.round(rng.uniform(0.3, 1.0, n), 4),
            state=state,
            occluder=np.where(state == 1, 1 + (k % n_tracks), -1).astype(np.int64),
            visibility=np.where(state == 1, 2, 0).astype(np.int8),
            hidden_frames=(state != 0).astype(np.int64),
        )
    events = [Event(f, "missing_detections", (1 + f % n_tracks,)) for f in range(0, n_frames, 7)]
    Scene(tracks, events, np.arange(n_frames), fps=30.0, image_size=(1920, 1080)).save(path)


def peak_mb(code: str, path: Path) -> tuple[float, float]:
    """Peak resident memory (MB) and wall time (s) of ``code`` run in a fresh process."""
    # VmHWM, not ru_maxrss: a child's ru_maxrss starts from its parent's at the fork
    script = (
        f"import sys; P = sys.argv[1]\n{code}\n"
        "print(next(l for l in open('/proc/self/status') if l.startswith('VmHWM')).split()[1])"
    )
    src = Path(__file__).resolve().parents[1] / "src"
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", script, str(path)],
        check=True,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(src)},
    )
    wall = time.perf_counter() - t0
    return int(out.stdout.split()[-1]) / 1024, wall


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=30_000)
    ap.add_argument("--tracks", type=int, default=22)
    ap.add_argument("--keep", type=Path, default=None, help="write the scene file here")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = a.keep or Path(tmp) / "scene.json"
        write_scene(path, a.frames, a.tracks)
        size = path.stat().st_size / 2**20
        print(f"scene: {a.tracks} tracks x {a.frames} frames, {size:.1f} MB")
        base = 0.0
        for name, code in _READ.items():
            mb, wall = peak_mb(code, path)
            base = base or mb
            above = (mb - base) / size
            print(
                f"  {name:24s} peak {mb:7.1f} MB, {above:4.2f} x the file above imports, "
                f"{wall:5.2f} s"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

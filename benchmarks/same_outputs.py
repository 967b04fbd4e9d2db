"""Are this checkout's files byte-identical to another checkout's on every shared sequence?

For every sequence of every benchmark in ``../shared/data`` both versions run ``sensemaking
track`` with ``--output --events --warnings --scene`` (each in a fresh process, the other
checkout's ``src/`` first on ``PYTHONPATH``), and the four files are compared byte by byte. It
prints one line per sequence (``same`` or the files that differ) and exits 1 when any differs:
the guard of a re-housing that must not change behaviour.

    git worktree add /tmp/old <commit>
    python benchmarks/same_outputs.py --other /tmp/old/src [--only kitti-rrc-car mot15] [--max 2]
"""

from __future__ import annotations

import argparse
import filecmp
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
OUTPUTS = {"--output": "tracks.txt", "--events": "events.jsonl", "--warnings": "warnings.jsonl"}


def _track(src: Path, spec: Any, source: Any, out: Path) -> str | None:
    """Run ``sensemaking track`` of the checkout ``src`` on one sequence into ``out``; the
    error text when it fails."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "sensemaking", "track", "--detections"]
    cmd += [str(source.det_path), "--format", spec.output_format]
    if spec.class_name:
        cmd += ["--class", spec.class_name]
    cmd += ["--seqinfo", str(source.seqinfo_path)]
    for option, name in OUTPUTS.items():
        cmd += [option, str(out / name)]
    cmd += ["--scene", str(out / "scene.json")]
    env = {**os.environ, "PYTHONPATH": str(src)}
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=out)
    return None if proc.returncode == 0 else proc.stderr.strip()[-500:]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--other", type=Path, required=True, help="the other checkout's src/ folder")
    ap.add_argument("--data", type=Path, default=None, help="default: ../shared/data")
    ap.add_argument("--only", nargs="*", default=None, help="benchmark names or patterns")
    ap.add_argument("--max", type=int, default=None, help="sequences per benchmark (default all)")
    args = ap.parse_args(argv)
    from sensemaking.benchmark.datasets import discover

    this = HERE.parent / "src"
    found = discover(args.data, args.only)
    differ = 0
    with tempfile.TemporaryDirectory() as tmp:
        for spec, sources in found.found:
            for source in sources[: args.max]:
                key = f"{spec.name}/{source.name}"
                a, b = Path(tmp) / "this" / key, Path(tmp) / "other" / key
                runs = (_track(this, spec, source, a), _track(args.other, spec, source, b))
                errors = [e for e in runs if e]
                if errors:
                    differ += 1
                    print(f"{key:40s} failed: {errors[0]}", flush=True)
                    continue
                names = [*OUTPUTS.values(), "scene.json"]
                bad = [n for n in names if not filecmp.cmp(a / n, b / n, shallow=False)]
                differ += bool(bad)
                print(f"{key:40s} {'differ: ' + ', '.join(bad) if bad else 'same'}", flush=True)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())

"""MOT17 sequences at a lower frame rate: every k-th frame, one data folder per offset.

Pedestrians seen at 10 fps, KITTI's rate, with MOTChallenge's visibility labels: the shared KITTI
sequences hold three pedestrian occlusion episodes, so this is where a change meant for
pedestrians at 10 fps can be seen at all (issue 27). Each offset o in 1..k keeps the frames
o, o+k, o+2k, ... of every sequence whose frame rate is a multiple of the target, renumbered
from 1, in a folder laid out like ``../shared/data``
(``OUT/o<o>/mot17/<sequence>/{det,gt,seqinfo.ini}``), so ``sensemaking benchmark --data
OUT/o1`` and ``../shared/verify/occlusion_recovery.py mot OUT/o1/mot17 ...`` read it as they
read the shared data.

    python benchmarks/subsampled_mot.py /tmp/mot10 --fps 10
    sensemaking benchmark --data /tmp/mot10/o1 --output /tmp/mot10/b1 --only mot17-yolox-halfval \
        --repeat 1 --no-crossval --no-explanations
"""

from __future__ import annotations

import argparse
import configparser
import sys
from pathlib import Path

from sensemaking.io.mot import read_seqinfo


def subsample_rows(lines: list[str], step: int, offset: int) -> list[str]:
    """MOT rows (``frame,...``) of frames ``offset, offset + step, ...``, renumbered from 1."""
    out = []
    for line in lines:
        head, sep, rest = line.partition(",")
        if not sep or not head.strip().isdigit():
            continue
        frame = int(head)
        if frame >= offset and (frame - offset) % step == 0:
            out.append(f"{(frame - offset) // step + 1},{rest}")
    return out


SOURCES = ("det/det.txt", "gt/gt.txt")


def write_sequence(
    ini: configparser.ConfigParser,
    rows: dict[str, list[str]],
    dst: Path,
    step: int,
    offset: int,
    fps: float,
    length: int,
) -> None:
    """One sequence's detections and ground truth (``rows`` of each of :data:`SOURCES`, as
    read) and its seqinfo (``ini``, ``length`` frames) at every ``step``-th frame."""
    ini["Sequence"]["frameRate"] = f"{fps:g}"
    ini["Sequence"]["seqLength"] = str((length - offset) // step + 1)
    for sub in SOURCES:
        (dst / sub).parent.mkdir(parents=True, exist_ok=True)
        (dst / sub).write_text("".join(subsample_rows(rows[sub], step, offset)))
    with open(dst / "seqinfo.ini", "w") as fh:
        ini.write(fh, space_around_delimiters=False)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", type=Path, help="folder for OUT/o1 .. OUT/o<k>")
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--fps", type=float, default=10.0, help="target frame rate (default 10)")
    ap.add_argument("--name", default="YOLOX-half", help="sequences whose name contains this")
    args = ap.parse_args(argv)
    root = args.data / "mot17"
    if not root.is_dir():
        print(f"subsampled_mot: {root}: no such folder", file=sys.stderr)
        return 2
    written = 0
    for src in sorted(p for p in root.iterdir() if args.name in p.name):
        info = read_seqinfo(src)
        rate = info.fps
        step = round(rate / args.fps)
        if step < 2 or abs(rate / step - args.fps) > 1e-6:
            print(f"skipped {src.name}: {rate:g} fps is not a multiple of {args.fps:g}")
            continue
        ini = configparser.ConfigParser()
        ini.optionxform = str  # type: ignore[assignment,method-assign]  # keep seqinfo's key case
        ini.read(src / "seqinfo.ini")
        rows = {sub: (src / sub).read_text().splitlines(keepends=True) for sub in SOURCES}
        for offset in range(1, step + 1):  # each source read once for all the offsets
            dst = args.out / f"o{offset}" / "mot17" / src.name
            write_sequence(ini, rows, dst, step, offset, args.fps, info.length)
        written += 1
        print(f"{src.name}: {rate:g} fps -> {args.fps:g} fps, offsets 1..{step}")
    return 0 if written else 2


if __name__ == "__main__":
    sys.exit(main())

"""Load whole benchmarks (ground truth + one tracker's results) from the usual folder layouts.

- MOTChallenge: ``<gt>/<seq>/gt/gt.txt`` and ``<gt>/<seq>/seqinfo.ini``;
  results ``<results>/<seq>.txt``.
- KITTI: ``<gt>/label_02/<seq>.txt`` and ``<gt>/seqinfo.csv``; results ``<results>/<seq>.txt``.

Either side may also be a single file (one sequence). Which sequences: the seqmap when given
(a name per line, optional ``name`` header; KITTI's ``0000 empty 000000 000154`` lines work too),
else every sequence of the ground truth. Sequence lengths come from ``seqinfo.ini`` /
``seqinfo.csv``; without them they are inferred from the boxes. Problems raise
:class:`~sensemaking.errors.InputError` naming the file: unknown sequence names in the seqmap, a
missing results file (unless ``missing_as_empty``: then the tracker output is empty), results in
frames beyond the sequence length.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.evaluation.core import SequenceInput
from sensemaking.io.text import read_input_text

__all__ = ["read_seqmap", "load_mot_benchmark", "load_kitti_benchmark"]

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]


def _seqmap_entries(path: PathLike) -> list[tuple[str, int]]:
    p = Path(path)
    try:
        text = read_input_text(p)
    except FileNotFoundError:
        raise InputError("no such seqmap file", p) from None
    except IsADirectoryError:
        raise InputError("is a directory, expected a seqmap file", p) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read seqmap: {exc}", p) from None
    out: list[tuple[str, int]] = []
    seen: dict[str, int] = {}
    for lineno, line in enumerate(text.splitlines(), start=1):
        fields = line.replace(",", " ").split()
        if not fields:
            continue
        name = fields[0]
        if not out and not seen and name.lower() == "name":
            continue  # MOTChallenge header
        if name in seen:
            raise InputError(
                f"sequence {name!r} listed twice (first on line {seen[name]})", p, lineno
            )
        seen[name] = lineno
        out.append((name, lineno))
    if not out:
        raise InputError("seqmap lists no sequences", p)
    return out


def read_seqmap(path: PathLike) -> list[str]:
    """Sequence names listed in a seqmap file (first field of each non-empty line)."""
    return [name for name, _ in _seqmap_entries(path)]


def _select(available: dict[str, Path], seqmap: PathLike | None, where: str) -> list[str]:
    if seqmap is None:
        if not available:
            raise InputError(f"no sequences found ({where})")
        return sorted(available)
    names = []
    for name, line in _seqmap_entries(seqmap):
        if name not in available:
            known = ", ".join(sorted(available)[:8]) + (", ..." if len(available) > 8 else "")
            raise InputError(
                f"unknown sequence {name!r}: not in the ground truth ({where}; "
                f"known: {known or 'none'})",
                seqmap,
                line,
            )
        names.append(name)
    return names


def _results_for(
    results: Path, names: list[str], missing_as_empty: bool
) -> dict[str, Path | None]:
    if results.is_file():
        if len(names) != 1:
            raise InputError(
                f"is a single file, but {len(names)} sequences are to be evaluated; "
                "give a folder of <sequence>.txt files",
                results,
            )
        return {names[0]: results}
    if not results.is_dir():
        raise InputError("no such results file or folder", results)
    out: dict[str, Path | None] = {}
    missing = []
    for name in names:
        f = results / f"{name}.txt"
        if f.is_file():
            out[name] = f
        elif missing_as_empty:
            log.warning("%s: no results file, scored as an empty tracker output", f)
            out[name] = None
        else:
            missing.append(name)
    if missing:
        listed = ", ".join(f"{n}.txt" for n in missing[:6]) + (", ..." if len(missing) > 6 else "")
        raise InputError(
            f"no results for {len(missing)} sequence(s): {listed} "
            "(use missing_as_empty / --missing-as-empty to score them as empty)",
            results,
        )
    extra = sorted(p.stem for p in results.glob("*.txt") if p.stem not in names)
    if extra:
        log.info("%s: ignoring results of sequences not evaluated: %s", results, ", ".join(extra))
    return out


def load_mot_benchmark(
    gt: PathLike,
    results: PathLike,
    *,
    seqmap: PathLike | None = None,
    missing_as_empty: bool = False,
) -> dict[str, SequenceInput]:
    """Ground truth and results of a MOTChallenge-layout benchmark, by sequence name.

    ``gt`` is a benchmark folder (``<seq>/gt/gt.txt`` inside), one sequence folder, or one
    file (``<seq>/gt/gt.txt``, ``<seq>/gt.txt`` or ``<seq>.txt``: the sequence is named after
    ``<seq>``); ``results`` a folder of ``<seq>.txt`` or one file.
    """
    from sensemaking.io.mot import read_mot, read_seqinfo

    g = Path(gt)
    if g.is_file():
        # <seq>/gt/gt.txt, <seq>/gt.txt or <seq>.txt
        seq_dir = g.parent.parent if g.parent.name == "gt" else g.parent
        name = g.stem if g.stem != "gt" else seq_dir.name
        available = {name: seq_dir}
        gt_files = {name: g}
    elif (g / "gt" / "gt.txt").is_file():
        available = {g.name: g}
        gt_files = {g.name: g / "gt" / "gt.txt"}
    elif g.is_dir():
        available = {p.name: p for p in g.iterdir() if (p / "gt" / "gt.txt").is_file()}
        gt_files = {n: p / "gt" / "gt.txt" for n, p in available.items()}
    else:
        raise InputError("no such ground-truth file or folder", g)
    names = _select(available, seqmap, f"{g}: sequence folders with gt/gt.txt")
    res = _results_for(Path(results), names, missing_as_empty)
    out: dict[str, SequenceInput] = {}
    for name in names:
        ini = available[name] / "seqinfo.ini"
        n_frames = read_seqinfo(ini).length if ini.is_file() else None
        if n_frames is None:
            log.info(
                "%s: no seqinfo.ini, sequence length inferred from the boxes", available[name]
            )
        rp = res[name]
        out[name] = SequenceInput(
            gt=read_mot(gt_files[name], kind="gt"),
            tracks=Detections.empty() if rp is None else read_mot(rp, kind="results"),
            n_frames=n_frames,
            gt_path=gt_files[name],
            tracks_path=rp,
        )
    return out


def load_kitti_benchmark(
    gt: PathLike,
    results: PathLike,
    *,
    seqmap: PathLike | None = None,
    missing_as_empty: bool = False,
) -> dict[str, SequenceInput]:
    """Ground truth and results of a KITTI-tracking-layout benchmark, by sequence name.

    ``gt`` is the folder holding ``label_02/`` (and ``seqinfo.csv``), the ``label_02`` folder
    itself, or one label file; ``results`` a folder of ``<seq>.txt`` or one file.
    """
    from sensemaking.io.kitti import read_kitti_labels, read_kitti_seqinfo

    g = Path(gt)
    if g.is_file():
        labels = {g.stem: g}
        roots = [g.parent, g.parent.parent]
    elif (g / "label_02").is_dir():
        labels = {p.stem: p for p in (g / "label_02").glob("*.txt")}
        roots = [g]
    elif g.is_dir():
        labels = {p.stem: p for p in g.glob("*.txt")}
        roots = [g, g.parent]
    else:
        raise InputError("no such ground-truth file or folder", g)
    info = {}
    for root in roots:
        csv = root / "seqinfo.csv"
        if csv.is_file():
            info = read_kitti_seqinfo(csv)
            break
    names = _select(labels, seqmap, f"{g}: label files <seq>.txt")
    res = _results_for(Path(results), names, missing_as_empty)
    out: dict[str, SequenceInput] = {}
    for name in names:
        n_frames = info[name].length if name in info else None
        if n_frames is None:
            log.info(
                "%s: not in a seqinfo.csv, sequence length inferred from the boxes", labels[name]
            )
        rp = res[name]
        out[name] = SequenceInput(
            gt=read_kitti_labels(labels[name]),
            tracks=Detections.empty() if rp is None else read_kitti_labels(rp),
            n_frames=n_frames,
            gt_path=labels[name],
            tracks_path=rp,
        )
    return out

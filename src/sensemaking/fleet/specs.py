"""What a batch runs: one :class:`SequenceSpec` per sequence, found under data roots or listed in
a manifest, and the checksum of its input files.

A data root is either a folder in the layouts :mod:`sensemaking.benchmark.datasets` reads
(``kitti/``, ``mot17/``, ``mot15/`` as in ``../shared/data``), or a manifest: a CSV file (or a
folder holding ``manifest.csv``) with one sequence per line. Manifest columns (header required;
``path`` and ``format`` required, the others optional; paths relative to the manifest)::

    dataset,sequence,path,format,class,fps,width,height,frames,gt,rules,logit_scores
    drive-a,0001,dets/0001.txt,mot,car,10,1242,375,200,gt/0001.txt,mot15,0

``dataset`` defaults to the manifest's folder name, ``sequence`` to the file's stem, ``class`` to
pedestrian (MOT) or the KITTI file's own classes, ``fps`` to 10 (KITTI) / 30 (MOT), the image
size to unknown (then the situations that need the ego corridor are skipped), ``frames`` to the
last frame with a detection, ``rules`` (the evaluation rules, needed with ``gt``) to
``kitti-<class>`` for KITTI. ``logit_scores`` 1 maps raw logit scores through a sigmoid.
"""

from __future__ import annotations

import csv
import hashlib
import io
import logging
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from sensemaking.errors import InputError
from sensemaking.io.text import read_input_text

__all__ = [
    "SequenceSpec",
    "find_sequences",
    "read_manifest",
    "input_checksums",
    "MANIFEST_COLUMNS",
]

log = logging.getLogger(__name__)

#: every column a manifest may have, in the documented order
MANIFEST_COLUMNS = (
    "dataset",
    "sequence",
    "path",
    "format",
    "class",
    "fps",
    "width",
    "height",
    "frames",
    "gt",
    "rules",
    "logit_scores",
)
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+-]*")
_RULES = ("mot17", "mot16", "mot20", "mot15", "kitti-car", "kitti-pedestrian")


@dataclass(frozen=True)
class SequenceSpec:
    """One sequence to track (picklable: it is a Ray task's argument).

    Attributes:
        dataset, sequence: the archive's partition names (letters, digits, ``._+-``).
        det_path: detections file. fmt: ``mot`` or ``kitti`` (its format).
        class_name: the class the detections are for (``car``, ``pedestrian``, ...), or None
            (MOT: pedestrian; KITTI labels-like files: each row's own class).
        fps: frames per second. image_size: ``(width, height)`` pixels, or None when unknown.
        n_frames: the sequence's length in frames, or None (up to the last detection).
        gt_path: ground truth for scoring, or None. rules: evaluation rules name (with gt).
        logit_scores: the scores are logits (sigmoid applied when read).
    """

    dataset: str
    sequence: str
    det_path: str
    fmt: str
    class_name: str | None = None
    fps: float | None = None
    image_size: tuple[int, int] | None = None
    n_frames: int | None = None
    gt_path: str | None = None
    rules: str | None = None
    logit_scores: bool = False

    @property
    def family(self) -> str:
        """The tracker's named parameter set: ``kitti`` or ``mot``."""
        return "kitti" if self.fmt == "kitti" else "mot"

    @property
    def first_frame(self) -> int:
        """0 for KITTI files, 1 for MOTChallenge files."""
        return 0 if self.fmt == "kitti" else 1

    @property
    def inputs(self) -> tuple[str, ...]:
        """The files whose content the results depend on."""
        return (self.det_path,) + ((self.gt_path,) if self.gt_path else ())

    @property
    def cost(self) -> int:
        """A size estimate for scheduling the longest first (bytes of detections)."""
        try:
            return Path(self.det_path).stat().st_size
        except OSError:
            return 0


def input_checksums(spec: SequenceSpec) -> dict[str, str]:
    """sha256 (hex) of each input file by role (``det``, ``gt``); a file that cannot be read
    hashes as ``unreadable: <error>`` (its sequence then fails when run, with the reason)."""
    out: dict[str, str] = {}
    for role, path in zip(("det", "gt"), spec.inputs, strict=False):  # gt may be absent
        h = hashlib.sha256()
        try:
            with open(path, "rb") as fh:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
            out[role] = h.hexdigest()
        except OSError as exc:
            out[role] = f"unreadable: {type(exc).__name__}"
    return out


def _check_name(value: str, what: str, where: Path, line: int | None = None) -> str:
    if not _NAME.fullmatch(value):
        raise InputError(
            f"{what} {value!r} must be letters, digits and ._+- (it names a folder)", where, line
        )
    return value


# -- discovery in the benchmark layouts ---------------------------------------------------------
def _from_layout(root: Path) -> tuple[list[SequenceSpec], list[str]]:
    from sensemaking.benchmark.datasets import discover
    from sensemaking.io.kitti import read_kitti_seqinfo
    from sensemaking.io.mot import read_seqinfo

    found = discover(root)
    specs: list[SequenceSpec] = []
    skipped = found.all_skipped() if found.found else []
    kitti_infos: dict[Path, dict] = {}
    for bench, sources in found.found:
        for src in sources:
            if bench.family == "kitti":
                if src.seqinfo_path not in kitti_infos:
                    kitti_infos[src.seqinfo_path] = read_kitti_seqinfo(src.seqinfo_path)
                info = kitti_infos[src.seqinfo_path].get(src.name)
                if info is None:
                    skipped.append(
                        f"{bench.name}: sequence {src.name} skipped, not in "
                        f"{src.seqinfo_path.name}"
                    )
                    continue
                rules = f"kitti-{bench.class_name}"
            else:
                info = read_seqinfo(src.seqinfo_path)
                rules = bench.rules
            specs.append(
                SequenceSpec(
                    dataset=bench.name,
                    sequence=src.name,
                    det_path=str(src.det_path),
                    fmt=bench.output_format,
                    class_name=bench.class_name or "pedestrian",
                    fps=float(info.fps),
                    image_size=(int(info.width), int(info.height)),
                    n_frames=int(info.length),
                    gt_path=str(src.gt_path),
                    rules=rules,
                    logit_scores=bench.logit_scores,
                )
            )
    more, why = _mot_folders(root, {Path(s.det_path).resolve() for s in specs})
    return specs + more, skipped + why


#: folders searched for MOT sequences below a data root (root/dataset/split/sequence)
_MOT_DEPTH = 4


def _mot_folders(root: Path, known: set[Path]) -> tuple[list[SequenceSpec], list[str]]:
    """MOTChallenge sequences by their layout (``seqinfo.ini`` beside ``det/det.txt``) that the
    benchmarks' own discovery did not take (e.g. MOT17's DPM and SDP detections), and the
    folders with a ``seqinfo.ini`` that are skipped, with the reason."""
    from sensemaking.io.mot import read_seqinfo

    specs: list[SequenceSpec] = []
    skipped: list[str] = []
    found: list[Path] = []
    level = [root]
    for _ in range(_MOT_DEPTH):  # breadth first, bounded: no walk of a whole disk
        nxt: list[Path] = []
        for d in level:
            try:
                children = sorted(c for c in d.iterdir() if c.is_dir() and not c.is_symlink())
            except OSError:
                continue
            for c in children:
                (found if (c / "seqinfo.ini").is_file() else nxt).append(c)
        level = nxt
    for folder in found:
        det = folder / "det" / "det.txt"
        if not det.is_file():
            skipped.append(f"{folder}: has seqinfo.ini but no det/det.txt")
            continue
        if det.resolve() in known:
            continue
        try:
            info = read_seqinfo(folder / "seqinfo.ini")
        except InputError as exc:
            skipped.append(f"{folder}: {exc}")
            continue
        rel = folder.parent.relative_to(root)
        dataset = "-".join(rel.parts) if rel.parts else root.name
        dataset = re.sub(r"[^A-Za-z0-9._+-]", "_", dataset.lower()) or "mot"
        gt = folder / "gt" / "gt.txt"
        name = folder.name.upper()
        rules = next(
            (r for r in ("mot20", "mot16", "mot15") if name.startswith(r.upper())), "mot17"
        )
        specs.append(
            SequenceSpec(
                dataset=dataset,
                sequence=re.sub(r"[^A-Za-z0-9._+-]", "_", folder.name),
                det_path=str(det),
                fmt="mot",
                class_name="pedestrian",
                fps=float(info.fps),
                image_size=(int(info.width), int(info.height)),
                n_frames=int(info.length),
                gt_path=str(gt) if gt.is_file() else None,
                rules=rules if gt.is_file() else None,
            )
        )
    return specs, skipped


# -- manifests ----------------------------------------------------------------------------------
def _opt_number(row: dict[str, str], key: str, conv, where: Path, line: int):
    from sensemaking.config import MAX_FPS, MAX_IMAGE_SIDE, MIN_FPS

    text = (row.get(key) or "").strip()
    if not text:
        return None
    try:
        value = conv(text)
    except ValueError:
        raise InputError(f"column {key!r}: not a number: {text!r}", where, line) from None
    if not value > 0:
        raise InputError(f"column {key!r} must be positive, got {text!r}", where, line)
    # the bounds the tracker holds a sequence to, checked here where the line is known (a
    # length is not bounded: frames past the content make no work)
    side = (1, MAX_IMAGE_SIDE)
    bounds = {"fps": (MIN_FPS, int(MAX_FPS)), "width": side, "height": side}.get(key)
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        low, high = bounds
        raise InputError(f"column {key!r} must be in [{low:g}, {high}], got {text!r}", where, line)
    return value


def read_manifest(path: str | Path) -> list[SequenceSpec]:
    """The sequences a manifest CSV lists (format in the module docstring).

    Raises:
        InputError: the file is missing or unreadable, a required column is absent, or a line
            has a bad value (naming the file and line).
    """
    p = Path(path)
    try:
        text = read_input_text(p, "utf-8-sig")
    except FileNotFoundError:
        raise InputError("manifest not found", p) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read manifest: {exc}", p) from None
    reader = csv.DictReader(io.StringIO(text))
    try:
        return _manifest_rows(p, reader)
    except csv.Error as exc:
        raise InputError(f"not a valid CSV file: {exc}", p, reader.line_num + 1) from None


def _manifest_rows(p: Path, reader: csv.DictReader) -> list[SequenceSpec]:
    from sensemaking.classes import CLASS_IDS

    columns = [c.strip() for c in reader.fieldnames or []]
    missing = [c for c in ("path", "format") if c not in columns]
    if missing:
        raise InputError(
            f"manifest header must name columns path and format (missing "
            f"{', '.join(missing)}); known columns: {', '.join(MANIFEST_COLUMNS)}",
            p,
            1,
        )
    unknown = [c for c in columns if c not in MANIFEST_COLUMNS]
    if unknown:
        raise InputError(
            f"unknown manifest column(s) {', '.join(unknown)}; known: "
            f"{', '.join(MANIFEST_COLUMNS)}",
            p,
            1,
        )
    specs: list[SequenceSpec] = []
    lines: dict[tuple[str, str], int] = {}  # (dataset, sequence) -> its line
    base = p.parent
    for raw in reader:
        line = reader.line_num
        row = {(k or "").strip(): (v or "").strip() for k, v in raw.items() if k is not None}
        if None in raw:
            raise InputError("more fields than the header names", p, line)
        fmt = row.get("format", "").lower()
        if fmt not in ("mot", "kitti"):
            raise InputError(
                f"column 'format' must be mot or kitti, got {row.get('format')!r}", p, line
            )
        if not row.get("path"):
            raise InputError("column 'path' is empty", p, line)
        det = base / row["path"]
        cls = row.get("class") or None
        if cls is not None and cls.lower() not in CLASS_IDS:
            raise InputError(
                f"unknown class {cls!r} (known: {', '.join(sorted(CLASS_IDS))})", p, line
            )
        width = _opt_number(row, "width", int, p, line)
        height = _opt_number(row, "height", int, p, line)
        if (width is None) != (height is None):
            raise InputError("give both width and height, or neither", p, line)
        gt = row.get("gt") or None
        rules = (row.get("rules") or "").lower() or None
        if gt and rules is None:
            if fmt != "kitti" or cls is None:
                raise InputError(
                    f"column 'rules' is needed with 'gt' (one of {', '.join(_RULES)})", p, line
                )
            rules = f"kitti-{cls.lower()}"
        if rules is not None and rules not in _RULES:
            raise InputError(
                f"column 'rules' must be one of {', '.join(_RULES)}, got {rules!r}", p, line
            )
        logit = (row.get("logit_scores") or "0").lower()
        if logit not in ("0", "1", "true", "false", "yes", "no"):
            raise InputError(f"column 'logit_scores' must be 0 or 1, got {logit!r}", p, line)
        specs.append(
            SequenceSpec(
                dataset=_check_name(row.get("dataset") or base.resolve().name, "dataset", p, line),
                sequence=_check_name(row.get("sequence") or det.stem, "sequence", p, line),
                det_path=str(det),
                fmt=fmt,
                class_name=cls.lower() if cls else None,
                fps=_opt_number(row, "fps", float, p, line),
                image_size=None if width is None else (width, height),
                n_frames=_opt_number(row, "frames", int, p, line),
                gt_path=str(base / gt) if gt else None,
                rules=rules,
                logit_scores=logit in ("1", "true", "yes"),
            )
        )
        key = (specs[-1].dataset, specs[-1].sequence)
        if key in lines:
            raise InputError(
                f"dataset {key[0]!r} sequence {key[1]!r} is listed twice (first on line "
                f"{lines[key]})",
                p,
                line,
            )
        lines[key] = line
    return specs


def find_sequences(roots: Iterable[str | Path]) -> tuple[list[SequenceSpec], list[str]]:
    """Every sequence under the data roots (benchmark layouts or manifests), and what was skipped.

    Raises:
        InputError: a root does not exist, holds no sequence, or two roots give the same
            dataset and sequence.
    """
    specs: list[SequenceSpec] = []
    skipped: list[str] = []
    why: list[str]
    for root in roots:
        r = Path(root)
        if r.is_file():
            found, why = read_manifest(r), []
        elif (r / "manifest.csv").is_file():
            found, why = read_manifest(r / "manifest.csv"), []
        elif r.is_dir():
            found, why = _from_layout(r)
        else:
            raise InputError("data root not found (a folder or a manifest .csv)", r)
        if not found:
            raise InputError(
                "no sequences found (expected kitti/, mot17/, mot15/ as in "
                "../shared/data, or a manifest.csv)",
                r,
            )
        specs.extend(found)
        skipped.extend(why)
    seen: dict[tuple[str, str], str] = {}
    for s in specs:
        key = (s.dataset, s.sequence)
        if key in seen:
            raise InputError(
                f"dataset {s.dataset!r} sequence {s.sequence!r} is listed twice "
                f"({seen[key]} and {s.det_path})"
            )
        seen[key] = s.det_path
    for msg in skipped:
        log.info("skipped: %s", msg)
    return specs, skipped

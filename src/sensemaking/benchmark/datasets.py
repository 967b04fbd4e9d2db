"""Find every benchmark in a data folder laid out like ``../shared/data`` and load its sequences.

Layout (see ``../shared/data/README.md``)::

    kitti/training/seqinfo.csv                         frames, image size, fps per sequence
    kitti/training/label_02/00XX.txt                   ground truth (all classes)
    kitti/detections/{rrc,pointrcnn}/{car,pedestrian}/00XX.txt
    mot17/MOT17-XX-YOLOX-half/{seqinfo.ini,det/det.txt,gt/gt.txt}
    mot17/MOT17-05-FRCNN/{seqinfo.ini,det/det.txt,gt/gt.txt}
    mot15/<name>/{seqinfo.ini,det/det.txt,gt/gt.txt}

A folder missing parts is not an error: whatever is complete is run, and every missing piece is
listed in :attr:`Discovery.skipped` so the report can say what was left out.
"""

from __future__ import annotations

import fnmatch
import logging
from collections.abc import Iterable, Iterator
from collections.abc import Sequence as SequenceABC
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from sensemaking.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.detections import Detections
    from sensemaking.io.mot import SequenceInfo

__all__ = [
    "BenchmarkSpec",
    "SequenceSource",
    "Sequence",
    "Benchmark",
    "Discovery",
    "SPECS",
    "default_data_root",
    "discover",
    "load_benchmark",
    "iter_benchmarks",
    "select_specs",
]

log = logging.getLogger(__name__)

Family = Literal["kitti", "motchallenge"]
Rules = Literal["kitti", "mot17", "mot15"]


@dataclass(frozen=True)
class BenchmarkSpec:
    """What a benchmark is, independent of where its files are.

    Attributes:
        name: short id used on the command line and in file names, e.g. ``kitti-rrc-car``.
        title: one line for the report.
        family: which named parameter set of our tracker applies (``kitti`` / ``motchallenge``).
        rules: the evaluation rules (``kitti``, ``mot17``, ``mot15``) of
            :mod:`sensemaking.evaluation`.
        output_format: the format results are written in (``kitti`` or ``mot``).
        class_name: the one class evaluated (KITTI), or None (MOTChallenge: pedestrians).
        detector: detector folder name (KITTI) or sequence-name suffix (MOT17).
        paper: key of the paper's Table 2 block quoted beside this benchmark, or None.
        note: one remark for the report (empty: none).
        logit_scores: the detector's scores are logits (for the report); the loader, which is
            ``sensemaking track``'s (:func:`sensemaking.io.formats.read_detections`), maps them
            through a sigmoid to probabilities in (0, 1) before any tracker sees them, so that
            every tracker's score thresholds mean what they say.
    """

    name: str
    title: str
    family: Family
    rules: Rules
    output_format: Literal["kitti", "mot"]
    class_name: str | None = None
    detector: str | None = None
    paper: str | None = None
    note: str = ""
    logit_scores: bool = False


_POINTRCNN_NOTE = (
    "PointRCNN scores are raw logits (often negative, many low-score false positives); "
    "the loader maps them through a sigmoid to (0, 1), the same input for every tracker."
)

#: every benchmark the runner knows, in report order
SPECS: tuple[BenchmarkSpec, ...] = (
    BenchmarkSpec(
        "kitti-rrc-car",
        "KITTI tracking training 0000-0010, Car, RRC detections",
        "kitti",
        "kitti",
        "kitti",
        "car",
        "rrc",
        "kitti-cars",
    ),
    BenchmarkSpec(
        "kitti-rrc-pedestrian",
        "KITTI tracking training 0000-0010, Pedestrian, RRC detections",
        "kitti",
        "kitti",
        "kitti",
        "pedestrian",
        "rrc",
        "kitti-pedestrians",
    ),
    BenchmarkSpec(
        "kitti-pointrcnn-car",
        "KITTI tracking training 0000-0010, Car, PointRCNN detections",
        "kitti",
        "kitti",
        "kitti",
        "car",
        "pointrcnn",
        "kitti-cars",
        _POINTRCNN_NOTE,
        True,
    ),
    BenchmarkSpec(
        "kitti-pointrcnn-pedestrian",
        "KITTI tracking training 0000-0010, Pedestrian, PointRCNN detections",
        "kitti",
        "kitti",
        "kitti",
        "pedestrian",
        "pointrcnn",
        "kitti-pedestrians",
        _POINTRCNN_NOTE,
        True,
    ),
    BenchmarkSpec(
        "mot17-yolox-halfval",
        "MOT17 half-val (02, 04, 05, 09), YOLOX-X detections",
        "motchallenge",
        "mot17",
        "mot",
        None,
        "YOLOX-half",
        None,
    ),
    BenchmarkSpec(
        "mot17-frcnn",
        "MOT17-05, public Faster R-CNN detections",
        "motchallenge",
        "mot17",
        "mot",
        None,
        "FRCNN",
        "mot17",
        "The paper's MOT17 rows use these public Faster R-CNN detections on all 7 training "
        "sequences; only MOT17-05 is here.",
    ),
    BenchmarkSpec(
        "mot15",
        "2D MOT 2015 train (6 sequences), Faster R-CNN detections",
        "motchallenge",
        "mot15",
        "mot",
        None,
        None,
        None,
    ),
)


@dataclass(frozen=True)
class SequenceSource:
    """Where one sequence's files are (nothing read yet)."""

    name: str
    det_path: Path
    gt_path: Path
    seqinfo_path: Path


@dataclass(frozen=True, eq=False)
class Sequence:
    """One loaded sequence.

    Attributes:
        name: sequence name (``0000``, ``MOT17-02-YOLOX-half``, ...).
        detections: every detection of the sequence (``frame`` set as in the file).
        gt_path: the ground-truth file the evaluator reads.
        info: name, length, image size and frame rate.
        det_path: the detection file.
        first_frame: number of the first frame (0 for KITTI, 1 for MOTChallenge).
    """

    name: str
    detections: Detections
    gt_path: Path
    info: SequenceInfo
    det_path: Path
    first_frame: int

    @property
    def frame_numbers(self) -> range:
        """Every frame of the sequence, including frames without detections."""
        assert self.detections.frame is not None  # set by Detections.__post_init__
        last_det = (
            int(self.detections.frame.max()) if len(self.detections) else self.first_frame - 1
        )
        last = max(self.first_frame + int(self.info.length) - 1, last_det)
        return range(self.first_frame, last + 1)


@dataclass(frozen=True, eq=False)
class Benchmark:
    """A benchmark with its sequences loaded, plus what was missing for it."""

    spec: BenchmarkSpec
    sequences: list[Sequence]
    skipped: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def rules(self) -> str:
        return self.spec.rules

    @property
    def n_frames(self) -> int:
        return sum(len(s.frame_numbers) for s in self.sequences)


@dataclass(frozen=True)
class Discovery:
    """What :func:`discover` found: per benchmark the complete sequences, and what was skipped."""

    root: Path
    found: list[tuple[BenchmarkSpec, list[SequenceSource]]]
    skipped: dict[str, list[str]]

    @property
    def names(self) -> list[str]:
        return [spec.name for spec, _ in self.found]

    def all_skipped(self) -> list[str]:
        """Every skip message, prefixed with its benchmark."""
        return [f"{name}: {msg}" for name, msgs in self.skipped.items() for msg in msgs]


# -------------------------------------------------------------------------------------------
def default_data_root() -> Path:
    """``../shared/data`` relative to the working directory, else relative to the repository."""
    cwd_candidate = Path.cwd() / ".." / "shared" / "data"
    if cwd_candidate.is_dir():
        return cwd_candidate.resolve()
    # src/sensemaking/benchmark/datasets.py -> repository root is parents[3] in a source checkout
    repo_candidate = Path(__file__).resolve().parents[3] / ".." / "shared" / "data"
    if repo_candidate.is_dir():
        return repo_candidate.resolve()
    return cwd_candidate


def select_specs(only: Iterable[str] | None) -> list[BenchmarkSpec]:
    """The specs named by ``only`` (exact names, globs like ``kitti-*``, or prefixes like
    ``kitti``).

    Raises:
        InputError: a pattern matches no known benchmark.
    """
    if only is None:
        return list(SPECS)
    patterns = [p.strip() for p in only if p and p.strip()]
    if not patterns:
        return list(SPECS)
    chosen: set[str] = set()
    for pat in patterns:
        hits = [
            s.name
            for s in SPECS
            if s.name == pat or fnmatch.fnmatchcase(s.name, pat) or s.name.startswith(pat + "-")
        ]
        if not hits:
            known = ", ".join(s.name for s in SPECS)
            raise InputError(f"unknown benchmark {pat!r}; known: {known}")
        chosen.update(hits)
    return [s for s in SPECS if s.name in chosen]


def _missing(paths: SequenceABC[Path], root: Path) -> list[str]:
    out = []
    for p in paths:
        if not p.is_file():
            try:
                out.append(str(p.relative_to(root)))
            except ValueError:
                out.append(str(p))
    return out


def _discover_kitti(root: Path, spec: BenchmarkSpec) -> tuple[list[SequenceSource], list[str]]:
    kitti = root / "kitti"
    seqinfo = kitti / "training" / "seqinfo.csv"
    labels = kitti / "training" / "label_02"
    dets = kitti / "detections" / str(spec.detector) / str(spec.class_name)
    if not kitti.is_dir():
        return [], ["no kitti/ folder"]
    if not seqinfo.is_file():
        return [], ["no kitti/training/seqinfo.csv"]
    if not dets.is_dir():
        return [], [f"no kitti/detections/{spec.detector}/{spec.class_name}/ folder"]
    names = sorted({p.stem for p in labels.glob("*.txt")} | {p.stem for p in dets.glob("*.txt")})
    found, skipped = [], []
    for name in names:
        src = SequenceSource(name, dets / f"{name}.txt", labels / f"{name}.txt", seqinfo)
        missing = _missing([src.det_path, src.gt_path], root)
        if missing:
            skipped.append(f"sequence {name} skipped, missing {', '.join(missing)}")
        else:
            found.append(src)
    return found, skipped


def _discover_mot(root: Path, spec: BenchmarkSpec) -> tuple[list[SequenceSource], list[str]]:
    folder = root / ("mot15" if spec.rules == "mot15" else "mot17")
    if not folder.is_dir():
        return [], [f"no {folder.name}/ folder"]
    if spec.rules == "mot15":
        dirs = sorted(p for p in folder.iterdir() if p.is_dir())
    else:
        dirs = sorted(p for p in folder.glob(f"MOT17-*-{spec.detector}") if p.is_dir())
    if not dirs:
        return [], [f"no sequences in {folder.name}/ for this benchmark"]
    found, skipped = [], []
    for d in dirs:
        src = SequenceSource(d.name, d / "det" / "det.txt", d / "gt" / "gt.txt", d / "seqinfo.ini")
        missing = _missing([src.det_path, src.gt_path, src.seqinfo_path], root)
        if missing:
            skipped.append(f"sequence {d.name} skipped, missing {', '.join(missing)}")
        else:
            found.append(src)
    return found, skipped


def discover(root: str | Path | None = None, only: Iterable[str] | None = None) -> Discovery:
    """Find the benchmarks under ``root`` (default :func:`default_data_root`) without reading data.

    Raises:
        InputError: ``root`` is not a folder, or ``only`` names an unknown benchmark.
    """
    root_path = Path(root) if root is not None else default_data_root()
    if not root_path.is_dir():
        raise InputError("benchmark data folder not found (pass --data PATH)", root_path)
    found: list[tuple[BenchmarkSpec, list[SequenceSource]]] = []
    skipped: dict[str, list[str]] = {}
    for spec in select_specs(only):
        if spec.family == "kitti":
            seqs, why = _discover_kitti(root_path, spec)
        else:
            seqs, why = _discover_mot(root_path, spec)
        if why:
            skipped[spec.name] = why
        if seqs:
            found.append((spec, seqs))
        else:
            skipped.setdefault(spec.name, []).append("benchmark skipped: no complete sequence")
    return Discovery(root_path, found, skipped)


# -------------------------------------------------------------------------------------------
def _with_class(dets: Detections, cid: int) -> Detections:
    import numpy as np

    if len(dets) and np.all(dets.class_id == cid):
        return dets
    return dets.with_(class_id=np.full(len(dets), cid, dtype=np.int64))


def _load_kitti(
    spec: BenchmarkSpec, sources: list[SequenceSource]
) -> tuple[list[Sequence], list[str]]:
    from sensemaking.classes import class_id
    from sensemaking.io.formats import read_detections
    from sensemaking.io.kitti import read_kitti_seqinfo

    infos = read_kitti_seqinfo(sources[0].seqinfo_path)
    out, skipped = [], []
    for src in sources:
        info = infos.get(src.name)
        if info is None:
            skipped.append(f"sequence {src.name} skipped, not in {src.seqinfo_path.name}")
            continue
        # the loading path of `sensemaking track` (PointRCNN logits -> probabilities included)
        dets = read_detections(src.det_path, "kitti", class_name=spec.class_name)
        dets = _with_class(dets, class_id(str(spec.class_name)))
        out.append(Sequence(src.name, dets, src.gt_path, info, src.det_path, first_frame=0))
    return out, skipped


def _load_mot(
    spec: BenchmarkSpec, sources: list[SequenceSource]
) -> tuple[list[Sequence], list[str]]:
    from sensemaking.classes import CLASS_IDS
    from sensemaking.io.formats import read_detections
    from sensemaking.io.mot import read_seqinfo

    out = []
    for src in sources:
        info = read_seqinfo(src.seqinfo_path)
        dets = _with_class(read_detections(src.det_path, "mot"), CLASS_IDS["pedestrian"])
        out.append(Sequence(src.name, dets, src.gt_path, info, src.det_path, first_frame=1))
    return out, []


def load_benchmark(
    spec: BenchmarkSpec, sources: list[SequenceSource], skipped: list[str] | None = None
) -> Benchmark:
    """Read the detections and sequence info of ``sources``."""
    if spec.family == "kitti":
        seqs, more = _load_kitti(spec, sources)
    else:
        seqs, more = _load_mot(spec, sources)
    return Benchmark(spec, seqs, list(skipped or []) + more)


def iter_benchmarks(
    root: str | Path | None = None, only: Iterable[str] | None = None
) -> Iterator[Benchmark]:
    """Discover, then load and yield each benchmark in report order (skips are in ``.skipped``)."""
    found = discover(root, only)
    for spec, sources in found.found:
        yield load_benchmark(spec, sources, found.skipped.get(spec.name))

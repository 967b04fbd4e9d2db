"""Read detections and write results by format name (MOTChallenge or KITTI); the table parsing
they share is :mod:`sensemaking.io.tables`."""

from __future__ import annotations

from typing import Literal

from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.io.kitti import read_kitti_detections, read_kitti_labels, write_kitti
from sensemaking.io.mot import read_mot, write_mot
from sensemaking.io.tables import PathLike, class_id_of, first_line

__all__ = ["Format", "read_detections", "write_results"]

Format = Literal["mot", "kitti"]


def read_detections(path: PathLike, fmt: Format, class_name: str | None = None) -> Detections:
    """Detections for the online tracker, sorted by frame.

    ``fmt="mot"``: a MOTChallenge ``det.txt`` (:func:`~sensemaking.io.mot.read_mot`, kind
    ``"det"``); ``class_name`` (if given) is the class of every box, else pedestrian.
    ``fmt="kitti"``: the file kind is sniffed from its first line: 17 or 18 space-separated
    fields is a label / tracking-result file, 6 comma-separated fields RRC detections (class from
    ``class_name`` or the parent folder), 15 comma-separated fields PointRCNN detections, whose
    logit scores are mapped through the sigmoid to probabilities (so that score thresholds mean the
    same for every detector; the benchmark runner reads through here too). An empty KITTI
    detection file (a sequence where the detector found nothing) gives empty Detections.
    """
    if fmt == "mot":
        default = 1 if class_name is None else class_id_of(class_name, path)
        return read_mot(path, kind="det", default_class=default)
    if fmt == "kitti":
        first = first_line(path)
        if first is None:
            return Detections.empty()
        lineno, line = first
        if "," in line:
            n = line.count(",") + 1
            if n in (6, 15):
                return read_kitti_detections(path, class_name=class_name)
            got = f"{n} comma-separated"
        else:
            n = len(line.split())
            if n in (17, 18):
                return read_kitti_labels(path)
            got = f"{n} space-separated"
        raise InputError(
            "cannot tell the KITTI file kind: expected 17 or 18 space-separated fields (labels or "
            "tracking results), 6 comma-separated (RRC detections) or 15 comma-separated "
            f"(PointRCNN detections), got {got}",
            path,
            lineno,
        )
    raise ValueError(f"unknown format {fmt!r}; expected 'mot' or 'kitti'")


def write_results(path: PathLike, tracks: Detections, fmt: Format) -> None:
    """Write tracks atomically: MOTChallenge results (``fmt="mot"``) or KITTI tracking results."""
    if fmt == "mot":
        write_mot(path, tracks)
    elif fmt == "kitti":
        write_kitti(path, tracks)
    else:
        raise ValueError(f"unknown format {fmt!r}; expected 'mot' or 'kitti'")

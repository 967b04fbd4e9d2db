"""Dataset scoring rules: which ground truth counts and which tracker boxes are removed.

The rules copy TrackEval's dataset classes exactly:

- ``MotChallenge2DBox`` (MOT16 / MOT17 / MOT20): only ground truth of class 1 (pedestrian) with
  consider flag 1 is scored; tracker boxes matched (IoU >= 0.5, Hungarian) to ground truth of a
  distractor class (2 person on vehicle, 7 static person, 8 distractor, 12 reflection; MOT20 also 6
  non-motorized vehicle) are removed first. Tracker boxes must be class <= 1.
- MOT15: no classes; every ground-truth row whose consider flag (column 7) is not 0 counts, no
  tracker box is removed. (Every row of the public 2D MOT 2015 ground truth has flag 1 except
  ETH-Bahnhof and PETS09-S2L1, where TrackEval drops the rows flagged 0; so do we.)
- ``Kitti2DBox``: Car and Pedestrian separately. Van (for Car) and Person_sitting (for Pedestrian)
  are distractors, as is ground truth with occluded > 2 or truncated > 0: tracker boxes matched to
  them are removed. Unmatched tracker boxes at most 25 px tall, or more than half inside a
  DontCare region, are removed. Ground-truth and tracker rows with a negative id are dropped.

IoU is plain ``intersection / union`` of the corner boxes, no ``+1`` pixel convention, for both
formats (MOT ``x, y, w, h`` is turned into corners by ``x2 = x + w``). Boxes partly or wholly
outside the image are evaluated as given, without clipping, as TrackEval does.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sensemaking.classes import CLASS_IDS

__all__ = ["DatasetRules", "get_rules", "rules_for_benchmark", "BENCHMARKS", "KITTI_CLASSES"]

#: benchmark names accepted by :func:`rules_for_benchmark`
BENCHMARKS = ("mot17", "mot16", "mot20", "mot15", "kitti")
#: classes KITTI is scored on (separately)
KITTI_CLASSES = ("car", "pedestrian")

_MOT_DISTRACTORS = tuple(
    CLASS_IDS[n] for n in ("person_on_vehicle", "static_person", "distractor", "reflection")
)


@dataclass(frozen=True)
class DatasetRules:
    """How one dataset family scores one class (see the module docstring for the presets).

    Attributes:
        benchmark: ``"mot17"``, ``"mot16"``, ``"mot20"``, ``"mot15"`` or ``"kitti"``.
        class_name: the scored class (``"pedestrian"`` or ``"car"``).
        gt_class: class id of the scored ground truth; None scores every row (MOT15).
        distractor_classes: gt class ids whose matched tracker boxes are removed.
        gt_classes_used: gt class ids read at all; None reads every row (MOT).
        valid_gt_classes: gt class ids allowed in the file; None allows any.
        tracker_class: only tracker boxes of this class are scored; None scores every box.
        max_tracker_class: tracker boxes of a class above this are an error (MOT: 1).
        use_consider_flag: drop gt rows whose ``data["consider"]`` is 0.
        max_occlusion, max_truncation: gt above these (``data["occluded"]`` /
            ``data["truncated"]``) is a distractor; None disables.
        min_height: unmatched tracker boxes at most this tall (pixels) are removed; None disables.
        use_dontcare: unmatched tracker boxes more than half inside a DontCare box are removed.
        drop_negative_ids: rows with a negative id are dropped (KITTI); otherwise an error.
        first_frame: number of the first frame (MOT 1, KITTI 0).
        threshold: IoU needed for a CLEAR / Identity match (TrackEval: 0.5).
    """

    benchmark: str
    class_name: str
    gt_class: int | None
    distractor_classes: tuple[int, ...] = ()
    gt_classes_used: tuple[int, ...] | None = None
    valid_gt_classes: tuple[int, ...] | None = None
    tracker_class: int | None = None
    max_tracker_class: int | None = None
    use_consider_flag: bool = True
    max_occlusion: int | None = None
    max_truncation: int | None = None
    min_height: float | None = None
    use_dontcare: bool = False
    drop_negative_ids: bool = False
    first_frame: int = 1
    threshold: float = 0.5
    match_distractors: bool = field(default=True)

    def __post_init__(self) -> None:
        if not 0.0 < self.threshold <= 1.0:
            raise ValueError(f"threshold must be in (0, 1], got {self.threshold}")

    @property
    def label(self) -> str:
        """``"mot17/pedestrian"``, ``"kitti/car"``, ..."""
        return f"{self.benchmark}/{self.class_name}"

    @property
    def is_kitti(self) -> bool:
        return self.benchmark == "kitti"


def _mot(benchmark: str) -> DatasetRules:
    if benchmark == "mot15":
        return DatasetRules(
            benchmark="mot15",
            class_name="pedestrian",
            gt_class=None,
            match_distractors=False,
            max_tracker_class=1,
            first_frame=1,
        )
    distractors = _MOT_DISTRACTORS
    if benchmark == "mot20":
        distractors = tuple(sorted(distractors + (CLASS_IDS["non_motorized_vehicle"],)))
    return DatasetRules(
        benchmark=benchmark,
        class_name="pedestrian",
        gt_class=CLASS_IDS["pedestrian"],
        distractor_classes=distractors,
        valid_gt_classes=tuple(range(1, 14)),
        max_tracker_class=1,
        first_frame=1,
    )


def _kitti(class_name: str) -> DatasetRules:
    if class_name == "car":
        cls, distractor = CLASS_IDS["car"], CLASS_IDS["van"]
    elif class_name == "pedestrian":
        cls, distractor = CLASS_IDS["pedestrian"], CLASS_IDS["person_sitting"]
    else:
        raise ValueError(f"KITTI scores only {', '.join(KITTI_CLASSES)}, not {class_name!r}")
    return DatasetRules(
        benchmark="kitti",
        class_name=class_name,
        gt_class=cls,
        distractor_classes=(distractor,),
        gt_classes_used=(cls, distractor),
        tracker_class=cls,
        use_consider_flag=False,
        max_occlusion=2,
        max_truncation=0,
        min_height=25.0,
        use_dontcare=True,
        drop_negative_ids=True,
        first_frame=0,
    )


def _norm(name: str) -> str:
    return name.strip().lower().replace("_", "-").replace(":", "-").replace("/", "-")


def get_rules(name: str | DatasetRules) -> DatasetRules:
    """Rules by name: ``mot17``, ``mot16``, ``mot20``, ``mot15``, ``kitti-car``,
    ``kitti-pedestrian``.

    Raises ValueError for an unknown name (or bare ``kitti``, which has two classes).
    """
    if isinstance(name, DatasetRules):
        return name
    key = _norm(name)
    if key in ("mot17", "mot16", "mot20", "mot15"):
        return _mot(key)
    if key.startswith("kitti-"):
        return _kitti(key[len("kitti-") :])
    if key == "kitti":
        raise ValueError(
            "KITTI scores car and pedestrian separately: use 'kitti-car' or 'kitti-pedestrian'"
        )
    raise ValueError(
        f"unknown dataset rules {name!r}; expected one of mot17, mot16, mot20, mot15, "
        "kitti-car, kitti-pedestrian"
    )


def rules_for_benchmark(
    benchmark: str, classes: list[str] | tuple[str, ...] | None = None
) -> list[DatasetRules]:
    """All rules of a benchmark: one per scored class (KITTI default: car and pedestrian)."""
    key = _norm(benchmark)
    if key.startswith("kitti-"):
        classes, key = [key[len("kitti-") :]], "kitti"
    if key == "kitti":
        names = [c.strip().lower() for c in (classes or KITTI_CLASSES)]
        return [_kitti(c) for c in names]
    if key in ("mot17", "mot16", "mot20", "mot15"):
        for c in classes or ():
            if c.strip().lower() != "pedestrian":
                raise ValueError(f"{key.upper()} scores only the pedestrian class, not {c!r}")
        return [_mot(key)]
    raise ValueError(f"unknown benchmark {benchmark!r}; expected one of {', '.join(BENCHMARKS)}")

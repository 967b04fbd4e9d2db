"""One class vocabulary for every dataset: names <-> integer ids.

Ids 1-13 follow MOTChallenge 2017 ground truth (1 = pedestrian, 3 = car, ...); KITTI's types
extend them. ``class_id`` in :class:`~sensemaking.detections.Detections` always uses these ids,
so class-aware tracking works the same on MOT and KITTI data.
"""

from __future__ import annotations

from typing import Final

#: canonical lower-case name -> id
CLASS_IDS: Final[dict[str, int]] = {
    "pedestrian": 1,
    "person_on_vehicle": 2,
    "car": 3,
    "bicycle": 4,
    "motorbike": 5,
    "non_motorized_vehicle": 6,
    "static_person": 7,
    "distractor": 8,
    "occluder": 9,
    "occluder_on_ground": 10,
    "occluder_full": 11,
    "reflection": 12,
    "crowd": 13,
    "van": 14,
    "truck": 15,
    "cyclist": 16,
    "tram": 17,
    "misc": 18,
    "dontcare": 19,
    "person_sitting": 20,
}
CLASS_NAMES: Final[dict[int, str]] = {v: k for k, v in CLASS_IDS.items()}

#: KITTI spelling of each KITTI type
KITTI_NAMES: Final[dict[int, str]] = {
    CLASS_IDS["car"]: "Car",
    CLASS_IDS["van"]: "Van",
    CLASS_IDS["truck"]: "Truck",
    CLASS_IDS["pedestrian"]: "Pedestrian",
    CLASS_IDS["person_sitting"]: "Person",  # KITTI tracking spells a sitting person "Person"
    CLASS_IDS["cyclist"]: "Cyclist",
    CLASS_IDS["tram"]: "Tram",
    CLASS_IDS["misc"]: "Misc",
    CLASS_IDS["dontcare"]: "DontCare",
}

#: classes that are vehicles (can occlude others, overtake, block a lane)
VEHICLES: Final[frozenset[int]] = frozenset(
    CLASS_IDS[n] for n in ("car", "van", "truck", "tram", "motorbike", "non_motorized_vehicle")
)
#: classes that are people (vulnerable road users)
PEOPLE: Final[frozenset[int]] = frozenset(
    CLASS_IDS[n]
    for n in ("pedestrian", "person_on_vehicle", "static_person", "cyclist", "person_sitting")
)


#: other spellings people use for our classes
ALIASES: Final[dict[str, str]] = {"person": "person_sitting"}  # KITTI tracking labels


def class_id(name: str) -> int:
    """Id of a class name (case-insensitive; KITTI and MOT spellings). Raises KeyError."""
    key = name.strip().lower().replace(" ", "_").replace("-", "_")
    return CLASS_IDS[ALIASES.get(key, key)]


def class_name(cid: int) -> str:
    """Canonical name of a class id, or ``"class<id>"`` for ids outside the vocabulary."""
    return CLASS_NAMES.get(int(cid), f"class{int(cid)}")


def check_kitti_class(fmt: str | None, cid: int, where: str) -> None:
    """KITTI results name every class by a KITTI type: refuse (InputError) a class without one
    when ``fmt`` is ``"kitti"``."""
    from sensemaking.errors import InputError

    if fmt == "kitti" and cid not in KITTI_NAMES:
        raise InputError(
            f"{where}: KITTI results have no type for it (KITTI types: "
            f"{', '.join(KITTI_NAMES.values())})"
        )

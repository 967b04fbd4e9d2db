"""Identity through occlusion: does an object keep its track id after it was hidden?

An *occlusion episode* of a ground-truth object: it is visible at frame ``a``, not visible on any
frame ``a+1 .. b-1`` and *hidden* on at least ``min_gap`` of them, and visible again at ``b``.

- KITTI (``label_02``, one class): visible = labelled with ``occluded <= 1`` and a box at least
  25 px tall; hidden = labelled and not visible, or not labelled between two labelled frames.
- MOT17 (``gt.txt``, class 1 with the consider flag): visible = visibility >= 0.5; hidden =
  visibility < 0.25 or not labelled (0.25 .. 0.5 is neither).

``min_gap`` is 3 frames at KITTI's 10 fps and ``max(3, round(0.2 fps))`` for MOT; the
reacquisition window ``max(5, round(0.35 fps))`` frames for MOT, 5 for KITTI. The tracker's id
before is that of the result box with the largest IoU (>= 0.5) against the object's box at
``a`` (none: *not tracked before*); after, the first frame of ``b .. b + window`` where the
object is labelled and a result box has IoU >= 0.5 with it. *Kept*: the same id; *switched*:
another; *lost*: no such box. Gap buckets (``b - a - 1`` frames): short < 10, medium 10-29,
long >= 30. This is the reference definition of ``../shared/verify/occlusion_recovery.py``,
restated on :class:`~sensemaking.detections.Detections` (a test checks count for count).

Pure functions: :func:`kitti_episodes` / :func:`mot_episodes` judge one sequence and return its
:class:`Episode` list; :class:`OcclusionCounts` sums them (per sequence, pooled).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sensemaking.detections import Detections

__all__ = [
    "VERDICTS",
    "BUCKETS",
    "Episode",
    "OcclusionCounts",
    "kitti_episodes",
    "mot_episodes",
    "mot_windows",
    "occlusion_table",
    "bucket_of",
]

#: verdicts of an episode, in report order
VERDICTS = ("kept", "switched", "lost", "not tracked before")
#: gap length buckets (frames hidden between the two visible frames)
BUCKETS = ("short", "medium", "long")
#: KITTI: hidden frames needed for an episode, frames after ``b`` to find the object again
KITTI_MIN_GAP, KITTI_REACQUIRE = 3, 5
#: KITTI's visible box height, pixels
KITTI_MIN_HEIGHT = 25.0
#: MOT17 visibility: at least VISIBLE is visible, below HIDDEN is hidden
MOT_VISIBLE, MOT_HIDDEN = 0.5, 0.25
#: IoU a result box needs to carry the object's id
IOU = 0.5

Box = tuple[float, float, float, float]
#: object id -> frame -> (box x1 y1 x2 y2 px, visible)
Objects = dict[int, dict[int, tuple[Box, bool]]]
#: frame -> [(track id, box)] in the results file's line order
Results = dict[int, list[tuple[int, Box]]]


def bucket_of(gap: int) -> str:
    """Gap bucket of an episode hidden for ``gap`` frames."""
    return "short" if gap < 10 else "medium" if gap < 30 else "long"


@dataclass(frozen=True)
class Episode:
    """One occlusion episode and its verdict.

    ``a`` / ``b``: the visible frames before and after; ``gap`` = b - a - 1 frames;
    ``id_before`` / ``id_after``: the tracker's ids (None: no box of IoU >= 0.5);
    ``frame_after``: the frame ``id_after`` was read at (None when lost or not tracked)."""

    sequence: str
    obj: int
    a: int
    b: int
    verdict: str
    id_before: int | None
    id_after: int | None
    frame_after: int | None

    @property
    def gap(self) -> int:
        return self.b - self.a - 1

    @property
    def bucket(self) -> str:
        return bucket_of(self.gap)

    def to_json(self) -> dict[str, Any]:
        return {
            "sequence": self.sequence,
            "object": self.obj,
            "a": self.a,
            "b": self.b,
            "gap": self.gap,
            "verdict": self.verdict,
            "id_before": self.id_before,
            "id_after": self.id_after,
            "frame_after": self.frame_after,
        }


@dataclass
class OcclusionCounts:
    """Verdict counts, overall and by gap bucket (``by_gap[bucket][verdict]``; *not tracked
    before* is counted per bucket too)."""

    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(VERDICTS, 0))
    by_gap: dict[str, dict[str, int]] = field(
        default_factory=lambda: {b: dict.fromkeys(VERDICTS, 0) for b in BUCKETS}
    )

    @classmethod
    def of(cls, episodes: Iterable[Episode]) -> OcclusionCounts:
        out = cls()
        for e in episodes:
            out.counts[e.verdict] += 1
            out.by_gap[e.bucket][e.verdict] += 1
        return out

    def __add__(self, other: OcclusionCounts) -> OcclusionCounts:
        out = OcclusionCounts()
        for v in VERDICTS:
            out.counts[v] = self.counts[v] + other.counts[v]
            for b in BUCKETS:
                out.by_gap[b][v] = self.by_gap[b][v] + other.by_gap[b][v]
        return out

    @property
    def episodes(self) -> int:
        return sum(self.counts.values())

    @property
    def tracked_before(self) -> int:
        return self.counts["kept"] + self.counts["switched"] + self.counts["lost"]

    @property
    def kept_share(self) -> float:
        """Kept of the episodes tracked before, a fraction in [0, 1] (NaN when none)."""
        n = self.tracked_before
        return self.counts["kept"] / n if n else float("nan")

    def to_json(self) -> dict[str, Any]:
        share = self.kept_share
        return {
            "episodes": self.episodes,
            **{v.replace(" ", "_"): self.counts[v] for v in VERDICTS},
            "kept_of_tracked_before": None if share != share else share,
            "by_gap": {
                b: {v.replace(" ", "_"): n for v, n in self.by_gap[b].items()} for b in BUCKETS
            },
        }

    def line(self) -> str:
        """One line: counts, the kept share (%) and kept / tracked-before per bucket."""
        c = self.counts
        share = self.kept_share
        gaps = "; ".join(
            f"{b} {self.by_gap[b]['kept']}/"
            f"{sum(self.by_gap[b][v] for v in ('kept', 'switched', 'lost'))}"
            for b in BUCKETS
        )
        pct = "  n/a" if share != share else f"{100 * share:5.1f}"
        return (
            f"episodes {self.episodes:4d}  kept {c['kept']:4d}  switched {c['switched']:4d}  "
            f"lost {c['lost']:4d}  not tracked before {c['not tracked before']:4d}  "
            f"kept of tracked-before {pct} %  by gap (kept/tracked): {gaps}"
        )


def _iou(a: Box, b: Box) -> float:
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    i = ix * iy
    u = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - i
    return i / u if u > 0 else 0.0


def _id_at(res: Results, frame: int, box: Box) -> int | None:
    """Id of the result box of largest IoU with ``box`` (the first in file order on a tie), if
    that IoU is at least :data:`IOU`."""
    best, best_iou = None, -1.0
    for tid, rbox in res.get(frame, ()):
        v = _iou(rbox, box)
        if v > best_iou:
            best, best_iou = tid, v
    return best if best is not None and best_iou >= IOU else None


def _results(tracks: Detections, keep: np.ndarray | None = None) -> Results:
    """Result boxes by frame, in the file's line order (``source_row``) when known."""
    out: Results = {}
    if len(tracks) == 0:
        return out
    assert tracks.frame is not None and tracks.tracker_id is not None
    idx = np.arange(len(tracks)) if keep is None else np.flatnonzero(keep)
    if tracks.source_row is not None:
        idx = idx[np.argsort(tracks.source_row[idx], kind="stable")]
    for i in idx.tolist():
        box = tuple(float(x) for x in tracks.xyxy[i])
        out.setdefault(int(tracks.frame[i]), []).append((int(tracks.tracker_id[i]), box))  # type: ignore[arg-type]
    return out


def _judge(
    name: str,
    objs: Objects,
    hidden: Callable[[int, int], bool],
    res: Results,
    min_gap: int,
    reacquire: int,
) -> list[Episode]:
    out = []
    for k, obj in objs.items():
        vis = sorted(f for f, (_, v) in obj.items() if v)
        for a, b in zip(vis, vis[1:], strict=False):
            if sum(hidden(k, f) for f in range(a + 1, b)) < min_gap:
                continue
            before = _id_at(res, a, obj[a][0])
            if before is None:
                out.append(Episode(name, k, a, b, "not tracked before", None, None, None))
                continue
            after, at = None, None
            for f in range(b, b + reacquire + 1):
                if f in obj:
                    after = _id_at(res, f, obj[f][0])
                    if after is not None:
                        at = f
                        break
            verdict = "kept" if after == before else "lost" if after is None else "switched"
            out.append(Episode(name, k, a, b, verdict, before, after, at))
    return out


def kitti_episodes(
    gt: Detections, tracks: Detections, class_id: int, *, name: str = ""
) -> list[Episode]:
    """Episodes of one KITTI sequence for one class (``class_id``, e.g. ``classes.class_id(
    "car")``): ``gt`` from ``read_kitti_labels`` (``data["occluded"]``), ``tracks`` the tracker's
    results (rows of other classes are skipped)."""
    objs: Objects = {}
    if len(gt):
        assert gt.frame is not None and gt.tracker_id is not None and gt.class_id is not None
        occ = gt.data.get("occluded", np.zeros(len(gt), np.int64))
        for i in np.flatnonzero(gt.class_id == class_id).tolist():
            box = tuple(float(x) for x in gt.xyxy[i])
            visible = int(occ[i]) <= 1 and box[3] - box[1] >= KITTI_MIN_HEIGHT
            objs.setdefault(int(gt.tracker_id[i]), {})[int(gt.frame[i])] = (box, visible)  # type: ignore[assignment]
    keep = None if tracks.class_id is None else tracks.class_id == class_id
    res = _results(tracks, keep)

    def hidden(k: int, f: int) -> bool:
        o = objs[k].get(f)
        return o is None or not o[1]

    return _judge(name, objs, hidden, res, KITTI_MIN_GAP, KITTI_REACQUIRE)


def mot_windows(fps: float) -> tuple[int, int]:
    """(min_gap, reacquire) in frames at ``fps`` (MOT17: 0.2 s and 0.35 s, at least 3 and 5)."""
    return max(3, round(0.2 * fps)), max(5, round(0.35 * fps))


def mot_episodes(
    gt: Detections, tracks: Detections, fps: float, *, name: str = ""
) -> list[Episode]:
    """Episodes of one MOT17 sequence: ``gt`` from ``read_mot(kind="gt")`` (``data["consider"]``,
    ``data["visibility"]``; only class 1 with the consider flag counts), ``tracks`` the
    tracker's results, ``fps`` the sequence's frame rate."""
    objs: Objects = {}
    vis: dict[int, dict[int, float]] = {}
    if len(gt):
        assert gt.frame is not None and gt.tracker_id is not None and gt.class_id is not None
        consider = gt.data.get("consider", np.ones(len(gt), np.int64))
        visibility = gt.data.get("visibility", np.ones(len(gt)))
        for i in np.flatnonzero((gt.class_id == 1) & (consider == 1)).tolist():
            k, f, v = int(gt.tracker_id[i]), int(gt.frame[i]), float(visibility[i])
            box = tuple(float(x) for x in gt.xyxy[i])
            objs.setdefault(k, {})[f] = (box, v >= MOT_VISIBLE)  # type: ignore[assignment]
            vis.setdefault(k, {})[f] = v
    res = _results(tracks)

    def hidden(k: int, f: int) -> bool:
        v = vis[k].get(f)
        return v is None or v < MOT_HIDDEN

    min_gap, reacquire = mot_windows(fps)
    return _judge(name, objs, hidden, res, min_gap, reacquire)


def occlusion_table(per_sequence: Mapping[str, OcclusionCounts], title: str = "") -> str:
    """Text table: a line per sequence and the pooled line."""
    lines = [f"Identity through occlusion{f' ({title})' if title else ''}:"]
    width = max((len(n) for n in per_sequence), default=8)
    width = max(width, len("pooled"))
    total = OcclusionCounts()
    for name, c in per_sequence.items():
        lines.append(f"  {name:<{width}}  {c.line()}")
        total = total + c
    lines.append(f"  {'pooled':<{width}}  {total.line()}")
    return "\n".join(lines) + "\n"


def benchmark_occlusion(
    sequences: Mapping[str, Any],
    fmt: str,
    classes: Iterable[str] = ("car", "pedestrian"),
    fps: Mapping[str, float] | None = None,
) -> dict[str, dict[str, list[Episode]]]:
    """Episodes of loaded sequences (name -> :class:`~sensemaking.evaluation.SequenceInput`),
    as ``{label: {sequence: episodes}}``: a label per KITTI class (``fmt="kitti"``), one label
    ``"pedestrian"`` for MOT17 (``fps`` by sequence, default 30). This is what
    ``sensemaking evaluate`` and the benchmark report call."""
    from sensemaking.classes import KITTI_NAMES, class_id

    out: dict[str, dict[str, list[Episode]]] = {}
    if fmt == "kitti":
        for cls in classes:
            cid = class_id(cls)
            label = KITTI_NAMES.get(cid, cls).lower()
            out[label] = {
                n: kitti_episodes(s.gt, s.tracks, cid, name=n) for n, s in sequences.items()
            }
    else:
        rates = fps or {}
        out["pedestrian"] = {
            n: mot_episodes(s.gt, s.tracks, rates.get(n, 30.0), name=n)
            for n, s in sequences.items()
        }
    return out


def occlusion_json(episodes: Mapping[str, Mapping[str, list[Episode]]]) -> dict[str, Any]:
    """``{label: {"sequences": {name: counts}, "pooled": counts}}`` (counts as
    :meth:`OcclusionCounts.to_json`)."""
    doc: dict[str, Any] = {}
    for label, per_seq in episodes.items():
        counts = {n: OcclusionCounts.of(e) for n, e in per_seq.items()}
        pooled = sum(counts.values(), OcclusionCounts())
        doc[label] = {
            "sequences": {n: c.to_json() for n, c in counts.items()},
            "pooled": pooled.to_json(),
        }
    return doc

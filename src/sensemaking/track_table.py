"""The tracker's state: one row per live track, its columns and its Kalman filter side by side."""

from __future__ import annotations

import numpy as np

from sensemaking.config import MAX_DIRECTION_FRAMES
from sensemaking.motion import KalmanConfig, motion_bank
from sensemaking.results import TrackState

__all__ = ["TrackTable", "EndedTracks"]

#: at most this many ended tracks are kept to revive (``TrackerConfig.revive_s``): the latest
REVIVE_MAX = 16
#: observations kept in a track's trail (``TrackerConfig.direction_weight``): the longest span
#: its direction of motion is read over, plus one
TRAIL = MAX_DIRECTION_FRAMES + 1


class TrackTable:
    """Live tracks, row by row; every column is a (T,) array, row ``i`` of each is track ``i``.

    Attributes:
        id: track ids. cls: class ids. state: :class:`~sensemaking.results.TrackState`.
        occluder: id of the track it hides behind, -1 if none. vis: index into the
        visibility values (``abduction.problem.VISIBILITY_VALUES``). unseen: frames since last
        matched. hits: frames matched. conf: last detection score (detector units).
        confirmed: reported (enough hits). depth: metres along the optical axis at the last
        match (``Detections.depth``), NaN where its detector gives none. trail_frame:
        (T, TRAIL) frame numbers of the last observations, oldest first, -1 where none;
        trail_xy: (T, TRAIL, 2) their box centres (pixels); kept only with
        ``direction_weight`` (:meth:`record`). kf: the Kalman filters, one row per track.
    """

    #: the columns, with their dtypes
    COLUMNS: dict[str, type] = {
        "id": np.int64,
        "cls": np.int64,
        "state": np.int64,
        "occluder": np.int64,
        "vis": np.int64,
        "unseen": np.int64,
        "hits": np.int64,
        "conf": np.float64,
        "confirmed": bool,
        "depth": np.float64,
        "trail_frame": np.int64,
        "trail_xy": np.float64,
    }
    #: the trailing dimensions of the columns that are not (T,)
    SHAPES: dict[str, tuple[int, ...]] = {"trail_frame": (TRAIL,), "trail_xy": (TRAIL, 2)}

    id: np.ndarray
    cls: np.ndarray
    state: np.ndarray
    occluder: np.ndarray
    vis: np.ndarray
    unseen: np.ndarray
    hits: np.ndarray
    conf: np.ndarray
    confirmed: np.ndarray
    depth: np.ndarray
    trail_frame: np.ndarray
    trail_xy: np.ndarray

    def __init__(self, kalman: KalmanConfig | None = None) -> None:
        self.kf = motion_bank(kalman)
        for name, dtype in self.COLUMNS.items():
            setattr(self, name, np.zeros((0, *self.SHAPES.get(name, ())), dtype=dtype))

    def __len__(self) -> int:
        return int(self.id.shape[0])

    def row_of(self) -> dict[int, int]:
        """``track id -> row`` for the current rows."""
        return {t: i for i, t in enumerate(self.id.tolist())}

    def add(
        self,
        ids: np.ndarray,
        xyxy: np.ndarray,
        cls: np.ndarray,
        conf: np.ndarray,
        vis: np.ndarray,
        velocity: np.ndarray | None = None,
        depth: np.ndarray | None = None,
    ) -> None:
        """Append K new visible tracks seen once: (K,) ids, (K, 4) boxes in pixels, classes,
        scores, visibility indices; ``velocity`` (4,) their prior velocity (pixels per frame);
        ``depth`` (K,) metres, NaN or None where unknown."""
        k = len(ids)
        self.kf.add(xyxy, velocity=velocity)
        new = {
            "id": ids,
            "cls": cls,
            "state": np.full(k, TrackState.VISIBLE),
            "occluder": np.full(k, -1),
            "vis": vis,
            "unseen": np.zeros(k),
            "hits": np.ones(k),
            "conf": conf,
            "confirmed": np.zeros(k, dtype=bool),
            "depth": np.full(k, np.nan) if depth is None else depth,
            "trail_frame": np.full((k, TRAIL), -1),
            "trail_xy": np.zeros((k, TRAIL, 2)),
        }
        for name, dtype in self.COLUMNS.items():
            setattr(
                self,
                name,
                np.concatenate([getattr(self, name), np.asarray(new[name]).astype(dtype)]),
            )

    def record(self, rows: np.ndarray, frame: int, xyxy: np.ndarray) -> None:
        """Append the observation of ``rows`` (K,) at ``frame``, boxes ``xyxy`` (K, 4) pixels, to
        their trails (the oldest drops out)."""
        f, xy = self.trail_frame, self.trail_xy
        f[rows, :-1] = f[rows, 1:]
        xy[rows, :-1] = xy[rows, 1:]
        f[rows, -1] = frame
        xy[rows, -1] = (xyxy[:, :2] + xyxy[:, 2:]) / 2

    def take(self, rows: np.ndarray) -> TrackTable:
        """A new table of ``rows`` (int array or (T,) bool mask), copied, filters included."""
        out = TrackTable(self.kf.config)
        out.kf = self.kf.take(rows)
        for name in self.COLUMNS:
            setattr(out, name, getattr(self, name)[rows].copy())
        return out

    def extend(self, other: TrackTable) -> None:
        """Append the rows of ``other`` (columns and filters) after this table's rows."""
        self.kf.extend(other.kf)
        for name in self.COLUMNS:
            setattr(self, name, np.concatenate([getattr(self, name), getattr(other, name)]))

    def drop(self, keep: np.ndarray) -> None:
        """Keep only the rows where the (T,) mask ``keep`` is True."""
        self.kf.remove(np.flatnonzero(~keep))
        for name in self.COLUMNS:
            setattr(self, name, getattr(self, name)[keep])

    def copy(self) -> TrackTable:
        """An independent copy (columns and Kalman filters)."""
        out = TrackTable(self.kf.config)
        out.kf = self.kf.copy()
        for name in self.COLUMNS:
            setattr(out, name, getattr(self, name).copy())
        return out


class EndedTracks:
    """Tracks that ended a moment ago and may be found again (``TrackerConfig.revive_s``).

    Attributes:
        table: their rows as they were when they ended (``unseen`` counts on while gone; the
            filters move on only when their prediction is continued). how: (G,) index into
            ``abduction.problem.GONE_EVENTS`` (0: left the field of view, 1: lost). age: (G,)
            updates since each ended.
    """

    def __init__(self, kalman: KalmanConfig | None = None) -> None:
        self.table = TrackTable(kalman)
        self.how = np.zeros(0, dtype=np.int64)
        self.age = np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.table)

    def add(self, rows: TrackTable, how: np.ndarray) -> None:
        """Keep the ended ``rows`` with how each ended; the oldest go past ``REVIVE_MAX``."""
        self.table.extend(rows)
        self.how = np.concatenate([self.how, np.asarray(how, dtype=np.int64)])
        self.age = np.concatenate([self.age, np.zeros(len(rows), dtype=np.int64)])
        if len(self) > REVIVE_MAX:
            self.keep(np.arange(len(self)) >= len(self) - REVIVE_MAX)

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the rows where the (G,) mask is True."""
        self.table.drop(mask)
        self.how, self.age = self.how[mask], self.age[mask]

    def pop(self, ids: list[int]) -> TrackTable:
        """Remove the tracks ``ids`` and return their rows (in the order of ``ids``)."""
        pos = self.table.row_of()
        rows = np.array([pos[t] for t in ids], dtype=np.int64)
        out = self.table.take(rows)
        mask = np.ones(len(self), dtype=bool)
        mask[rows] = False
        self.keep(mask)
        return out

    def copy(self) -> EndedTracks:
        """An independent copy (rows, Kalman filters, how and age)."""
        out = EndedTracks(self.table.kf.config)
        out.table = self.table.copy()
        out.how, out.age = self.how.copy(), self.age.copy()
        return out

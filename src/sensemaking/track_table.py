"""The tracker's state: one row per live track, its columns and its Kalman filter side by side."""

from __future__ import annotations

import numpy as np

from sensemaking.motion import KalmanBank, KalmanConfig
from sensemaking.results import TrackState

__all__ = ["TrackTable"]


class TrackTable:
    """Live tracks, row by row; every column is a (T,) array, row ``i`` of each is track ``i``.

    Attributes:
        id: track ids. cls: class ids. state: :class:`~sensemaking.results.TrackState`.
        occluder: id of the track it hides behind, -1 if none. vis: index into the
        visibility values (``abduction.problem.VISIBILITY_VALUES``). unseen: frames since last
        matched. hits: frames matched. conf: last detection score (detector units).
        confirmed: reported (enough hits). depth: metres along the optical axis at the last
        match (``Detections.depth``), NaN where its detector gives none. kf: the Kalman
        filters, one row per track.
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
    }

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

    def __init__(self, kalman: KalmanConfig | None = None) -> None:
        self.kf = KalmanBank(kalman)
        for name, dtype in self.COLUMNS.items():
            setattr(self, name, np.zeros(0, dtype=dtype))

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
        }
        for name, dtype in self.COLUMNS.items():
            setattr(
                self,
                name,
                np.concatenate([getattr(self, name), np.asarray(new[name]).astype(dtype)]),
            )

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

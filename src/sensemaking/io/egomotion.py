"""The ego-motion file: the camera vehicle's own speed (and yaw rate) per frame.

Format (CSV, UTF-8, ``#`` starts a comment line)::

    frame,speed_mps,yaw_rate_rad_s
    0,8.31,0.000
    1,8.35,-0.012
    ...

* ``frame``: integer frame number (the numbering of the detections file), strictly increasing.
* ``speed_mps``: the ego vehicle's forward speed, metres per second (>= 0; a car backing up is
  not supported).
* ``yaw_rate_rad_s`` (optional column): turn rate, radians per second, positive turning left
  (counter-clockwise seen from above, the ISO 8855 / KITTI OXTS ``wu`` sign).

The header line is required; its names say which columns there are (the yaw column may be
left out). Between two listed frames the values are interpolated linearly; outside the listed
frames the ego motion is unknown (the scene estimate is used there). KITTI OXTS users:
``speed_mps`` is ``vf`` (forward velocity) and ``yaw_rate_rad_s`` is ``wu``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from os import PathLike

import numpy as np

from sensemaking.errors import InputError
from sensemaking.io.tables import read_text

__all__ = ["EgoMotion", "read_ego_motion", "parse_ego_motion", "EGO_COLUMNS"]

#: the columns of an ego-motion file, in order; the last one is optional
EGO_COLUMNS: tuple[str, ...] = ("frame", "speed_mps", "yaw_rate_rad_s")
#: fastest ego speed accepted, m/s (about 540 km/h: a typo, not a car)
MAX_SPEED_MPS = 150.0
#: fastest turn accepted, rad/s (a car turning on the spot at walking pace stays far below)
MAX_YAW_RATE = 10.0


@dataclass(frozen=True, eq=False)
class EgoMotion:
    """Ego speed (m/s) and yaw rate (rad/s, + left) at listed frames, interpolated between.

    Attributes:
        frames: (N,) int64 frame numbers, strictly increasing.
        speed: (N,) float64 forward speed, m/s.
        yaw_rate: (N,) float64 yaw rate, rad/s, or None when the file has no such column.
        source: where it came from (a path), for messages.
    """

    frames: np.ndarray
    speed: np.ndarray
    yaw_rate: np.ndarray | None = None
    source: str = ""

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    def at(self, frame: int) -> tuple[float, float | None] | None:
        """``(speed m/s, yaw rate rad/s or None)`` at ``frame``; None outside the listed frames."""
        fr = self.frames
        if not len(fr) or frame < fr[0] or frame > fr[-1]:
            return None
        v = float(np.interp(frame, fr, self.speed))
        w = None if self.yaw_rate is None else float(np.interp(frame, fr, self.yaw_rate))
        return v, w


def _number(text: str, what: str, path: str, line: int) -> float:
    try:
        x = float(text)
    except ValueError:
        raise InputError(f"{what} is not a number: {text.strip()!r}", path, line) from None
    if not math.isfinite(x):
        raise InputError(f"{what} must be finite, got {text.strip()!r}", path, line)
    return x


def parse_ego_motion(text: str, path: str = "<ego motion>") -> EgoMotion:
    """An :class:`EgoMotion` from the text of an ego-motion file. Raises InputError naming the
    file and the 1-based line of the first problem."""
    header: list[str] | None = None
    frames: list[int] = []
    speeds: list[float] = []
    yaws: list[float] = []
    for line_no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        cells = [c.strip() for c in line.split(",")]
        if header is None:
            names = [c.lower() for c in cells]
            if names not in (list(EGO_COLUMNS[:2]), list(EGO_COLUMNS)):
                raise InputError(
                    f"the header must be '{','.join(EGO_COLUMNS)}' (the last column optional), "
                    f"got {line!r}",
                    path,
                    line_no,
                )
            header = names
            continue
        if len(cells) != len(header):
            raise InputError(
                f"expected {len(header)} comma-separated values ({','.join(header)}), "
                f"got {len(cells)}",
                path,
                line_no,
            )
        f = _number(cells[0], "frame", path, line_no)
        if f != int(f) or f < 0:
            raise InputError(f"frame must be an integer >= 0, got {cells[0]!r}", path, line_no)
        if frames and int(f) <= frames[-1]:
            raise InputError(
                f"frames must increase: frame {int(f)} after frame {frames[-1]}", path, line_no
            )
        v = _number(cells[1], "speed_mps", path, line_no)
        if not 0.0 <= v <= MAX_SPEED_MPS:
            raise InputError(
                f"speed_mps must be in [0, {MAX_SPEED_MPS:g}] m/s, got {v:g}", path, line_no
            )
        frames.append(int(f))
        speeds.append(v)
        if len(header) == 3:
            w = _number(cells[2], "yaw_rate_rad_s", path, line_no)
            if abs(w) > MAX_YAW_RATE:
                raise InputError(
                    f"yaw_rate_rad_s must be within +-{MAX_YAW_RATE:g} rad/s, got {w:g}",
                    path,
                    line_no,
                )
            yaws.append(w)
    if header is None:
        raise InputError(f"empty ego-motion file: need the header '{','.join(EGO_COLUMNS)}'", path)
    if not frames:
        raise InputError("the ego-motion file has a header but no rows", path)
    return EgoMotion(
        np.asarray(frames, dtype=np.int64),
        np.asarray(speeds, dtype=np.float64),
        np.asarray(yaws, dtype=np.float64) if len(header) == 3 else None,
        path,
    )


def read_ego_motion(path: str | PathLike[str]) -> EgoMotion:
    """Read an ego-motion CSV file (see the module docstring). Raises InputError."""
    return parse_ego_motion(read_text(path), str(path))

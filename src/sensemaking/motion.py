"""Vectorised constant-velocity Kalman filters predicting box position and size.

One :class:`KalmanBank` holds the filters of all live tracks as parallel arrays, so
``predict``/``update`` cost a handful of numpy operations whatever the number of tracks.

Model. The state of a track is ``cx, cy, w, h`` (box centre and size, pixels) and their
velocities (pixels/frame); each of the four coordinates moves at constant velocity,
independently of the others, and is measured directly (``H = [I 0]``). We filter ``w, h``
rather than DeepSORT's ``aspect, h``: a box that grows or shrinks at a constant rate
(an approaching car) is then exactly constant-velocity, ``w`` is in pixels like every other
coordinate so one noise model fits all four, and the ``min_size`` guard applies to ``w``
directly. Because the transition, process noise, measurement matrix and measurement noise
are all block-diagonal over the four coordinates, the 8x8 covariance stays a set of four
independent 2x2 blocks ``[[pp, pv], [pv, vv]]``; we store just those, (T, 4) arrays each,
and every predict/update is a closed-form elementwise update (exactly the 8x8 Kalman
equations, without the matmuls).

Noise scales with the box, as in DeepSORT (Wojke et al. 2017): standard deviations are
fractions of the box size -- width for ``cx, w`` and height for ``cy, h`` (DeepSORT uses the
height for all; for wide cars and thin pedestrians the per-axis size is the natural scale).
Scaling every noise term by the same factor leaves the Kalman gain, and so the predicted
boxes, unchanged; it only sets how large the covariance (for gating) is relative to the box.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sensemaking.config import KalmanConfig  # declared with the other parameters

__all__ = ["KalmanConfig", "KalmanBank", "PerspectiveBank", "motion_bank"]


# columns of the (T, 45) state array (one array: a row gather, scatter, append or delete is one
# numpy call for all quantities): the filter (20), its copy after the last correction (20) and
# the last measurement (4), which :meth:`KalmanBank.reupdate` starts from
_X, _PV, _V, _VV, _PP = slice(0, 4), slice(4, 8), slice(8, 12), slice(12, 16), slice(16, 20)
_FILTER, _FROZEN, _OBS = slice(0, 20), slice(20, 40), slice(40, 44)
# and the factor on the velocity noise's variance that ``velocity_adapt`` moves (1 when off)
_ADAPT = slice(44, 45)
_COLUMNS = 45
# the factor's bounds: velocity_std within 16x either way (DeepSORT's 1/160 to 0.1 and back)
_ADAPT_LOW, _ADAPT_HIGH = 1.0 / 256.0, 256.0
# geometric mean of chi-square(4) / 4, the normalised innovation of a consistent filter: the
# factor stands still on average where the filter's expectation is right
_NIS_GEOMEAN = float(np.exp(1.0 - np.euler_gamma - np.log(2.0)))  # exp(digamma(2)) / 2
# the noise scale of cx, cy, w, h is w, h, w, h (:meth:`KalmanBank._scale`)
_WHWH = np.array([2, 3, 2, 3], dtype=np.intp)


def _to_cxcywh(xyxy: np.ndarray) -> np.ndarray:
    x = np.asarray(xyxy, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 4:
        x = x.reshape(-1, 4)
    out = np.empty_like(x)
    out[:, 2:] = x[:, 2:] - x[:, :2]
    out[:, :2] = x[:, :2] + 0.5 * out[:, 2:]
    return out


def _to_xyxy(c: np.ndarray) -> np.ndarray:
    out = np.empty_like(c)
    half = 0.5 * c[:, 2:]
    out[:, :2] = c[:, :2] - half
    out[:, 2:] = c[:, :2] + half
    return out


class _Rows:
    """What the filter banks share: rows addressed by position, and the checks of the
    corrections' inputs. A bank defines ``__len__`` and ``_correct(idx, z)``, ``z`` (K, 4)
    ``cx, cy, w, h`` pixels."""

    __slots__ = ()

    def __len__(self) -> int:
        raise NotImplementedError

    def _correct(self, idx: np.ndarray, z: np.ndarray) -> None:
        raise NotImplementedError

    def _rows(self, index: np.ndarray) -> np.ndarray:
        idx = np.asarray(index)
        if idx.dtype == bool:
            if idx.shape != (len(self),):
                raise ValueError(f"boolean index must have shape ({len(self)},), got {idx.shape}")
            return np.flatnonzero(idx)
        idx = idx.astype(np.intp, copy=False).reshape(-1)
        if idx.size and (idx.min() < 0 or idx.max() >= len(self)):
            name = type(self).__name__
            raise IndexError(f"row index out of range for {name} of {len(self)} tracks")
        return idx

    def _steps(self, steps: int | np.ndarray) -> np.ndarray | int:
        if isinstance(steps, (int, np.integer)) and not isinstance(steps, bool):
            if steps < 0:
                raise ValueError(f"steps must be >= 0, got {steps}")
            return int(steps)
        n = np.asarray(steps)
        if n.ndim == 0:
            return self._steps(_as_int(n))
        if n.shape != (len(self),):
            raise ValueError(f"steps must be a scalar or have shape ({len(self)},), got {n.shape}")
        if n.dtype.kind not in "iu":
            if n.dtype.kind != "f" or not np.all(n == np.round(n)):
                raise ValueError("steps must be whole numbers of frames")
        if np.any(n < 0):
            raise ValueError("steps must be >= 0")
        return n.astype(np.float64)[:, None]

    def update(self, index: np.ndarray, xyxy: np.ndarray) -> None:
        """Correct rows ``index`` (K,), distinct, with measured boxes ``xyxy`` (K, 4) pixels."""
        idx = self._rows(index)
        z = _to_cxcywh(xyxy)
        if z.shape[0] != idx.size:
            raise ValueError(f"update: {idx.size} rows but {z.shape[0]} boxes")
        if idx.size == 0:
            return
        if len(set(idx.tolist())) != idx.size:
            raise ValueError("update: row indices must be distinct")
        if not np.all(np.isfinite(z)):
            raise ValueError("update: boxes must be finite")
        self._correct(idx, z)

    def update_trusted(self, index: np.ndarray, xyxy: np.ndarray) -> None:
        """:meth:`update` without its input checks, for callers that guarantee them (the
        tracker): ``index`` a (K,) int array of distinct rows in range, K >= 1, and ``xyxy``
        (K, 4) finite float boxes. Same arithmetic, so the same result."""
        self._correct(index, _to_cxcywh(xyxy))

    def _started(
        self, xyxy: np.ndarray, velocity: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``add``'s checked inputs: boxes ``cx, cy, w, h`` (K, 4) pixels and their prior
        velocities (K, 4) pixels per frame (0 where None)."""
        z = _to_cxcywh(xyxy)
        name = type(self).__name__
        if not np.all(np.isfinite(z)):
            raise ValueError(f"{name}.add: boxes must be finite")
        v0 = (
            np.zeros_like(z)
            if velocity is None
            else np.broadcast_to(np.asarray(velocity, float), z.shape)
        )
        if not np.all(np.isfinite(v0)):
            raise ValueError(f"{name}.add: velocities must be finite")
        return z, v0

    def reupdate(self, index: np.ndarray, xyxy: np.ndarray, gaps: np.ndarray) -> None:
        """Correct rows ``index`` (K,), distinct, seen again after ``gaps`` (K,) frames without a
        measurement, by the observation-centric re-update of OC-SORT (Cao et al. 2023): the
        filter goes back to its state after the last measurement and runs ``gap + 1`` steps of
        predict and correct along the straight line from that measurement to the new box
        ``xyxy`` (K, 4) pixels, so the velocity is re-estimated from the observations at both
        ends of the gap instead of being corrected once from the drifted prediction. A row with
        gap 0 is corrected as by :meth:`update`."""
        idx = self._rows(index)
        z = _to_cxcywh(xyxy)
        n = np.asarray(gaps).reshape(-1)
        if z.shape[0] != idx.size or n.size != idx.size:
            raise ValueError(f"reupdate: {idx.size} rows, {z.shape[0]} boxes, {n.size} gaps")
        if idx.size == 0:
            return
        if len(set(idx.tolist())) != idx.size:
            raise ValueError("reupdate: row indices must be distinct")
        if not np.all(np.isfinite(z)):
            raise ValueError("reupdate: boxes must be finite")
        if n.dtype.kind not in "iu" or np.any(n < 0):
            raise ValueError("reupdate: gaps must be non-negative integers (frames)")
        steps = n.astype(np.int64) + 1
        gapped = steps > 1
        work, last = self._rewound(idx, gapped)
        # rows without a gap keep their prediction (steps 0 in the first pass) and take one
        # correction like the others
        first = np.where(gapped, 1, 0)
        for k in range(1, int(steps.max()) + 1):
            live = steps >= k
            work.predict(np.where(live, 1, 0) if k > 1 else first)
            rows = np.flatnonzero(live)
            virtual = last[rows] + (k / steps[rows])[:, None] * (z[rows] - last[rows])
            work._correct(rows, virtual)
        self._put(idx, work)

    def _rewound(self, idx: np.ndarray, gapped: np.ndarray) -> tuple[Any, np.ndarray]:
        """:meth:`reupdate`'s working bank: rows ``idx`` copied, those ``gapped`` back at their
        state after their last correction; and those rows' last measurements (K, 4)."""
        raise NotImplementedError

    def _put(self, idx: np.ndarray, work: Any) -> None:
        """Rows ``idx`` replaced by the rows of the working bank ``work``, in order."""
        raise NotImplementedError

    def _shifted(
        self, index: np.ndarray, dxy: np.ndarray, dv: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``shift``'s checked inputs: rows (K,), the offset (2,) pixels and the velocity's
        (2,) pixels per frame (0 where None)."""
        idx = self._rows(index)
        d = np.asarray(dxy, dtype=np.float64).reshape(2)
        w = np.zeros(2) if dv is None else np.asarray(dv, dtype=np.float64).reshape(2)
        if not (np.all(np.isfinite(d)) and np.all(np.isfinite(w))):
            raise ValueError("shift: offsets must be finite")
        return idx, d, w

    def _damped(self, index: np.ndarray, factor: float) -> np.ndarray:
        """``damp``'s checked rows (K,): ``factor`` must be in [0, 1]."""
        idx = self._rows(index)
        if not 0.0 <= factor <= 1.0:
            raise ValueError(f"damp: factor must be in [0, 1], got {factor}")
        return idx


class KalmanBank(_Rows):
    """Kalman filters of T tracks. State per track: cx, cy, w, h and their velocities
    (pixels, pixels/frame); beside it, the filter as it was after its last correction and that
    measurement (for :meth:`reupdate`). Rows are addressed by position 0..T-1; :meth:`remove`
    compacts them. The pixel filter whatever ``perspective`` says: :func:`motion_bank` picks.
    """

    __slots__ = ("config", "_s", "_x", "_v", "_pp", "_pv", "_vv")

    def __init__(self, config: KalmanConfig | None = None) -> None:
        self.config = config if config is not None else KalmanConfig()
        self._bind(np.zeros((0, _COLUMNS)))

    def _bind(self, state: np.ndarray) -> None:
        """Hold the (T, 45) state array and its column views: one array, so that a row
        gather, scatter, append or delete is one numpy call for all its quantities."""
        self._s = state
        self._x = state[:, _X]  # (T, 4) cx, cy, w, h
        self._pv = state[:, _PV]  # (T, 4) covariance coordinate-velocity
        self._v = state[:, _V]  # (T, 4) their velocities
        self._vv = state[:, _VV]  # (T, 4) variance of each velocity
        self._pp = state[:, _PP]  # (T, 4) variance of each coordinate

    def __len__(self) -> int:
        return int(self._x.shape[0])

    def __repr__(self) -> str:
        return f"KalmanBank(n={len(self)})"

    # helpers ---------------------------------------------------------------------------
    @staticmethod
    def _scale(x: np.ndarray) -> np.ndarray:
        """(K, 4) noise scale per coordinate of ``cx, cy, w, h`` rows: w, h, w, h (pixels)."""
        return x[:, _WHWH]

    def _clamp_size(self, x: np.ndarray, v: np.ndarray | None) -> None:
        """Keep w, h >= min_size in place; a clamped size stops shrinking (velocity >= 0)."""
        size = x[:, 2:]
        low = size < self.config.min_size
        if low.any():
            size[low] = self.config.min_size
            if v is not None:
                vs = v[:, 2:]
                vs[low] = np.maximum(vs[low], 0.0)

    # public API ------------------------------------------------------------------------
    def add(self, xyxy: np.ndarray, velocity: np.ndarray | None = None) -> np.ndarray:
        """Start tracks at boxes ``xyxy`` (K, 4) pixels. Returns their row indices (K,).

        ``velocity``: (K, 4) or (4,) prior velocity of ``cx, cy, w, h`` in pixels per frame
        (default 0), with the uncertainty ``init_velocity_std``: it moves the first prediction,
        and the second detection corrects it in proportion to that uncertainty.
        """
        z, v0 = self._started(xyxy, velocity)
        self._clamp_size(z, None)
        cfg = self.config
        s = self._scale(z)
        start = len(self)
        new = np.zeros((z.shape[0], _COLUMNS))
        new[:, _X] = z
        new[:, _V] = v0
        new[:, _PP] = (cfg.init_position_std * s) ** 2
        new[:, _VV] = (cfg.init_velocity_std * s) ** 2
        new[:, _FROZEN] = new[:, _FILTER]
        new[:, _OBS] = z
        new[:, _ADAPT] = 1.0
        self._bind(np.concatenate([self._s, new]))
        return np.arange(start, start + z.shape[0], dtype=np.intp)

    def predict(self, steps: int | np.ndarray = 1) -> np.ndarray:
        """Advance every track ``steps`` frames (scalar or (T,) per track, >= 0; 0 = unchanged).

        Process noise is that of ``steps`` single-frame predictions, scaled by the box size
        before the call. Returns (T, 4) predicted boxes ``x1, y1, x2, y2``.
        """
        n = self._steps(steps)
        if isinstance(n, int) and n == 0:
            return _to_xyxy(self._x)
        cfg = self.config
        s2 = self._scale(self._x) ** 2
        qp = cfg.position_std**2 * s2
        qv = cfg.velocity_std**2 * s2
        if cfg.velocity_adapt > 0.0:
            qv = qv * self._s[:, _ADAPT]
        if isinstance(n, int) and n == 1:
            self._predict_one(qp, qv)
            return _to_xyxy(self._x)
        # sum_{k<n} F^k Q F^kT with F^k = [[1, k], [0, 1]] and Q = diag(qp, qv)
        n2 = n * n
        pp, pv, vv = self._pp, self._pv, self._vv
        # in place, each from the old values (pp before pv before vv)
        pp[...] = pp + 2.0 * n * pv + n2 * vv + n * qp + ((n - 1) * n * (2 * n - 1) / 6.0) * qv
        pv[...] = pv + n * vv + (n * (n - 1) / 2.0) * qv
        vv[...] = vv + n * qv
        self._x[...] = self._x + n * self._v
        self._clamp_size(self._x, self._v)
        return _to_xyxy(self._x)

    def _predict_one(self, qp: np.ndarray, qv: np.ndarray) -> None:
        """:meth:`predict`'s update at ``n = 1`` (the tracker's every frame), in place: the same
        sums without the products by 1 and the terms ``0.0 * qv`` (adding +0.0 changes no
        value here: the variances are positive and ``pv`` >= 0)."""
        pp, pv, vv = self._pp, self._pv, self._vv
        acc = 2.0 * pv
        acc += pp  # pp + 2 pv (addition is commutative, also in floating point)
        acc += vv
        acc += qp
        pp[...] = acc
        pv += vv
        vv += qv
        self._x += self._v
        self._clamp_size(self._x, self._v)

    def _correct(self, idx: np.ndarray, z: np.ndarray) -> None:
        """The Kalman correction of rows ``idx`` by measurements ``z`` (K, 4) ``cx, cy, w, h``."""
        rows = self._s[idx]  # (K, 20) copy, written back at the end
        x, v = rows[:, _X], rows[:, _V]
        pp, pv, vv = rows[:, _PP], rows[:, _PV], rows[:, _VV]
        r = (self.config.measurement_std * self._scale(x)) ** 2
        inv = 1.0 / (pp + r)
        innovation = z - x
        rate = self.config.velocity_adapt
        if rate > 0.0:
            # covariance matching: the innovations against what the filter expected of them
            nis = np.mean(innovation * innovation * inv, axis=1) / _NIS_GEOMEAN
            factor = rows[:, _ADAPT] * np.power(np.maximum(nis, 1e-12), rate)[:, None]
            rows[:, _ADAPT] = np.clip(factor, _ADAPT_LOW, _ADAPT_HIGH)
        x[...] = x + (pp * inv) * innovation
        v[...] = v + (pv * inv) * innovation
        self._clamp_size(x, v)
        # in place, each from the old values (vv needs the old pv)
        vv[...] = vv - pv * pv * inv
        pp[...] = pp * r * inv
        pv[...] = pv * r * inv
        rows[:, _FROZEN] = rows[:, _FILTER]
        rows[:, _OBS] = z
        self._s[idx] = rows

    def _rewound(self, idx: np.ndarray, gapped: np.ndarray) -> tuple[KalmanBank, np.ndarray]:
        work = KalmanBank(self.config)
        state = self._s[idx]  # (K, 45) copy
        state[gapped, _FILTER] = state[gapped, _FROZEN]
        work._bind(state)
        return work, state[:, _OBS].copy()

    def _put(self, idx: np.ndarray, work: KalmanBank) -> None:
        self._s[idx] = work._s

    def shift(self, index: np.ndarray, dxy: np.ndarray, dv: np.ndarray | None = None) -> None:
        """Move rows ``index`` (K,) by ``dxy`` (2,) pixels and change their ``cx, cy`` velocity by
        ``dv`` (2,) pixels/frame (default 0): the image motion of the camera. The copy after the
        last correction moves alike and the last measurement by ``dxy``; covariances are
        unchanged."""
        idx, d, w = self._shifted(index, dxy, dv)
        if idx.size == 0:
            return
        frozen = _FROZEN.start
        for offset, start in (
            (d, _X.start),
            (w, _V.start),
            (d, frozen + _X.start),
            (w, frozen + _V.start),
            (d, _OBS.start),
        ):
            self._s[idx, start : start + 2] += offset

    def damp(self, index: np.ndarray, factor: float) -> None:
        """Scale the velocities (centre and size) of rows ``index`` (K,) by ``factor`` in
        [0, 1]: an unseen object's image motion is less certain the longer it is unseen
        (issue 27). Covariances are unchanged."""
        self._v[self._damped(index, factor)] *= factor

    def remove(self, index: np.ndarray) -> None:
        """Drop rows ``index`` (int array or (T,) bool mask); the others keep their order."""
        idx = self._rows(index)
        if idx.size == 0:
            return
        self._bind(np.delete(self._s, idx, axis=0))

    def take(self, index: np.ndarray) -> KalmanBank:
        """A new bank of rows ``index`` (int array or (T,) bool mask), copied in that order."""
        out = KalmanBank(self.config)
        out._bind(self._s[self._rows(index)].copy())
        return out

    def extend(self, other: KalmanBank | PerspectiveBank) -> None:
        """Append the rows of ``other`` (their whole state) after this bank's rows."""
        if not isinstance(other, KalmanBank):
            raise TypeError("extend: a KalmanBank takes the rows of a KalmanBank only")
        self._bind(np.concatenate([self._s, other._s]))

    def observed(self) -> np.ndarray:
        """(T, 4) each row's last measurement as boxes ``x1, y1, x2, y2`` (pixels)."""
        return _to_xyxy(self._s[:, _OBS])

    def xyxy(self) -> np.ndarray:
        """(T, 4) current state as boxes ``x1, y1, x2, y2`` (pixels)."""
        return _to_xyxy(self._x)

    def cxcywh(self) -> np.ndarray:
        """(T, 4) current ``cx, cy, w, h`` (pixels)."""
        return self._x.copy()

    def velocity(self) -> np.ndarray:
        """(T, 4) current ``d(cx, cy, w, h)/frame`` (pixels/frame)."""
        return self._v.copy()

    def motion(self, index: np.ndarray) -> np.ndarray:
        """(K, 2, 2) of rows ``index``: ``[[cx, cy], [vcx, vcy]]`` (pixels, pixels/frame)."""
        idx = self._rows(index)
        return np.stack([self._x[idx, :2], self._v[idx, :2]], axis=1)

    def covariance(self) -> np.ndarray:
        """(T, 8, 8) state covariance, order ``cx, cy, w, h, vcx, vcy, vw, vh`` (for gating)."""
        t = len(self)
        out = np.zeros((t, 8, 8))
        i = np.arange(4)
        out[:, i, i] = self._pp
        out[:, i, i + 4] = self._pv
        out[:, i + 4, i] = self._pv
        out[:, i + 4, i + 4] = self._vv
        return out

    def peek(self, steps: int | np.ndarray) -> np.ndarray:
        """(T, 4) boxes extrapolated ``steps`` frames ahead (scalar or (T,)), state unchanged."""
        n = self._steps(steps)
        x = self._x + n * self._v
        self._clamp_size(x, None)
        return _to_xyxy(x)

    def copy(self) -> KalmanBank:
        """An independent copy (same config object)."""
        out = KalmanBank(self.config)
        out._bind(self._s.copy())
        return out


def _as_int(n: np.ndarray) -> int:
    value = n.item()
    if isinstance(value, float):
        if not value.is_integer():
            raise ValueError("steps must be whole numbers of frames")
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"steps must be an integer, got {value!r}")
    return value


class PerspectiveBank(_Rows):
    """Extended Kalman filters of T tracks seen through a pinhole camera (``KalmanConfig``'s
    ``perspective_x``/``_y`` set: the principal point ``x0, y0``, pixels).

    State per track: ``u = (cx - x0) / h``, ``v = (cy - y0) / h``, ``a = w / h``, ``r = 1 / h``
    (1/pixels) and their velocities per frame. Through a pinhole camera ``u, v, a`` are an
    object's world position and width over its height and ``r`` its depth over ``f H``, so an
    object moving at constant velocity relative to the camera -- a parked car passed by a
    driving camera, a person walking past a standing one -- is exactly constant-velocity, where
    in pixels the first accelerates away from ``x0``. Boxes are measured in pixels through the
    linearised projection (the detector's error stays a pixel error: ``u`` and ``r`` are
    measured together, not each with the other's error), so the covariance is a full 8x8.
    Noise levels as :class:`KalmanBank`'s, fractions of the box (process noise of ``u, v, a,
    r`` by ``a, 1, a, r``: the width, the height, the width, the height in pixels), except that
    the process noise of ``r`` and the first uncertainty of its rate are ``depth_noise`` times
    that: a box's height jitters more, frame to frame, than its object's depth changes, and this
    filter reads height as depth, moving the box along its ray. Same interface as
    :class:`KalmanBank`; boxes, velocities and motions come out in pixels.
    """

    __slots__ = ("config", "_c", "_x", "_p", "_fx", "_fp", "_obs")

    def __init__(self, config: KalmanConfig | None = None) -> None:
        self.config = config if config is not None else KalmanConfig()
        cfg = self.config
        if cfg.perspective_x is None or cfg.perspective_y is None:
            raise ValueError("PerspectiveBank needs its principal point (perspective_x, _y)")
        self._c = np.array([cfg.perspective_x, cfg.perspective_y], dtype=np.float64)
        self._x = np.zeros((0, 8))  # u, v, a, r and their velocities
        self._p = np.zeros((0, 8, 8))
        self._fx = np.zeros((0, 8))  # the filter after its last correction (reupdate)
        self._fp = np.zeros((0, 8, 8))
        self._obs = np.zeros((0, 4))  # that measurement, cx, cy, w, h pixels

    def __len__(self) -> int:
        return int(self._x.shape[0])

    def __repr__(self) -> str:
        return f"PerspectiveBank(n={len(self)})"

    # helpers ---------------------------------------------------------------------------
    def _parts(self) -> tuple[np.ndarray, ...]:
        return (self._x, self._p, self._fx, self._fp, self._obs)

    def _set(self, parts: tuple[np.ndarray, ...]) -> None:
        self._x, self._p, self._fx, self._fp, self._obs = parts

    def _scale(self, x: np.ndarray) -> np.ndarray:
        """(K, 4) process noise scale of ``u, v, a, r``: a, 1, a and ``depth_noise`` r."""
        return np.column_stack(
            [x[:, 2], np.ones(x.shape[0]), x[:, 2], self.config.depth_noise * x[:, 3]]
        )

    def _boxes(self, x: np.ndarray) -> np.ndarray:
        """(K, 4) ``cx, cy, w, h`` pixels of states ``x`` (K, >=4)."""
        h = 1.0 / x[:, 3]
        return np.column_stack([self._c + x[:, :2] * h[:, None], x[:, 2] * h, h])

    def _jacobian(self, x: np.ndarray) -> np.ndarray:
        """(K, 4, 4) d(cx, cy, w, h) / d(u, v, a, r) at states ``x``."""
        h = 1.0 / x[:, 3]
        j = np.zeros((x.shape[0], 4, 4))
        for i in range(3):
            j[:, i, i] = h
            j[:, i, 3] = -x[:, i] * h * h
        j[:, 3, 3] = -h * h
        return j

    def _state_of(self, c: np.ndarray, dc: np.ndarray, std: np.ndarray) -> tuple[np.ndarray, ...]:
        """States (K, 8) and covariances (K, 8, 8) of boxes ``c`` (K, 4) pixels moving at
        ``dc`` (K, 4) pixels/frame, with pixel stds ``std`` (K, 8) of both."""
        h = c[:, 3]
        r = 1.0 / h
        u = np.column_stack([(c[:, :2] - self._c) * r[:, None], c[:, 2] * r, r])
        dr = -dc[:, 3] * r * r
        du = np.column_stack(
            [
                dc[:, :2] * r[:, None] + (c[:, :2] - self._c) * dr[:, None],
                dc[:, 2] * r + c[:, 2] * dr,
                dr,
            ]
        )
        # inverse of the projection's Jacobian, at the box
        g = np.zeros((c.shape[0], 4, 4))
        for i in range(3):
            g[:, i, i] = r
            g[:, i, 3] = -u[:, i] * r
        g[:, 3, 3] = -r * r
        p = np.zeros((c.shape[0], 8, 8))
        p[:, :4, :4] = g @ (std[:, :4, None] ** 2 * np.swapaxes(g, 1, 2))
        p[:, 4:, 4:] = g @ (std[:, 4:, None] ** 2 * np.swapaxes(g, 1, 2))
        return np.column_stack([u, du]), p

    def _clamp(self, x: np.ndarray) -> None:
        """``r`` within [1e-6, 1/min_size] and ``a >= min_size r``, in place; a clamped
        coordinate stops moving past its bound."""
        lo, hi = 1e-6, 1.0 / self.config.min_size
        r, a = x[:, 3], x[:, 2]
        high, low = r > hi, r < lo
        if high.any() or low.any():
            r[high], r[low] = hi, lo
            x[high, 7] = np.minimum(x[high, 7], 0.0)
            x[low, 7] = np.maximum(x[low, 7], 0.0)
        thin = a < self.config.min_size * r
        if thin.any():
            a[thin] = self.config.min_size * r[thin]
            x[thin, 6] = np.maximum(x[thin, 6], 0.0)

    @staticmethod
    def _advance(
        x: np.ndarray, p: np.ndarray, n: np.ndarray, qp: np.ndarray, qv: np.ndarray
    ) -> None:
        """``n`` (K, 1) steps of constant velocity on states ``x`` and covariances ``p``, in
        place, with per-step process noise variances ``qp``, ``qv`` (K, 4)."""
        n3 = n[:, :, None]
        pp, pv, vp, vv = p[:, :4, :4], p[:, :4, 4:], p[:, 4:, :4], p[:, 4:, 4:]
        new_pp = pp + n3 * (pv + vp) + n3 * n3 * vv
        new_pv = pv + n3 * vv
        p[:, :4, :4] = new_pp
        p[:, :4, 4:] = new_pv
        p[:, 4:, :4] = np.swapaxes(new_pv, 1, 2)
        i = np.arange(4)
        p[:, i, i] += n * qp + ((n - 1) * n * (2 * n - 1) / 6.0) * qv
        p[:, i, i + 4] += (n * (n - 1) / 2.0) * qv
        p[:, i + 4, i] += (n * (n - 1) / 2.0) * qv
        p[:, i + 4, i + 4] += n * qv
        x[:, :4] += n * x[:, 4:]

    def _frames(self, steps: int | np.ndarray) -> np.ndarray:
        """(T, 1) frames each row is advanced (:meth:`_steps`' checks)."""
        n = self._steps(steps)
        return np.full((len(self), 1), float(n)) if isinstance(n, int) else n

    def _noise(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s2 = self._scale(x) ** 2
        return self.config.position_std**2 * s2, self.config.velocity_std**2 * s2

    def _correct(self, idx: np.ndarray, z: np.ndarray) -> None:
        """EKF correction of rows ``idx`` by boxes ``z`` (K, 4) ``cx, cy, w, h`` pixels."""
        x, p = self._x[idx], self._p[idx]
        j = self._jacobian(x)
        hm = np.zeros((idx.size, 4, 8))
        hm[:, :, :4] = j
        pred = self._boxes(x)
        r = (self.config.measurement_std * pred[:, [2, 3, 2, 3]]) ** 2
        pht = p @ np.swapaxes(hm, 1, 2)  # (K, 8, 4)
        s = hm @ pht
        i4 = np.arange(4)
        s[:, i4, i4] += r
        gain = np.swapaxes(np.linalg.solve(s, np.swapaxes(pht, 1, 2)), 1, 2)  # (K, 8, 4)
        x = x + (gain @ (z - pred)[:, :, None])[:, :, 0]
        p = p - gain @ s @ np.swapaxes(gain, 1, 2)
        p = 0.5 * (p + np.swapaxes(p, 1, 2))
        self._clamp(x)
        self._x[idx], self._p[idx] = x, p
        self._fx[idx], self._fp[idx] = x, p
        self._obs[idx] = z

    # public API ------------------------------------------------------------------------
    def add(self, xyxy: np.ndarray, velocity: np.ndarray | None = None) -> np.ndarray:
        """Start tracks at boxes ``xyxy`` (K, 4) pixels, prior velocity (K, 4) or (4,) pixels
        per frame (default 0). Returns their row indices (K,)."""
        z, v0 = self._started(xyxy, velocity)
        z[:, 2:] = np.maximum(z[:, 2:], self.config.min_size)
        cfg = self.config
        s = z[:, [2, 3, 2, 3]]
        # a depth rate from two boxes' heights is mostly their jitter (``depth_noise``)
        std = np.column_stack([cfg.init_position_std * s, cfg.init_velocity_std * s])
        std[:, 7] *= cfg.depth_noise
        x, p = self._state_of(z, v0, std)
        start = len(self)
        self._set(
            (
                np.concatenate([self._x, x]),
                np.concatenate([self._p, p]),
                np.concatenate([self._fx, x]),
                np.concatenate([self._fp, p]),
                np.concatenate([self._obs, z]),
            )
        )
        return np.arange(start, start + z.shape[0], dtype=np.intp)

    def predict(self, steps: int | np.ndarray = 1) -> np.ndarray:
        """Advance every track ``steps`` frames (scalar or (T,)); returns (T, 4) boxes."""
        n = self._frames(steps)
        qp, qv = self._noise(self._x)
        self._advance(self._x, self._p, n, qp, qv)
        self._clamp(self._x)
        return self.xyxy()

    def _rewound(self, idx: np.ndarray, gapped: np.ndarray) -> tuple[PerspectiveBank, np.ndarray]:
        work = self.take(idx)
        work._x[gapped], work._p[gapped] = work._fx[gapped], work._fp[gapped]
        return work, work._obs.copy()

    def _put(self, idx: np.ndarray, work: PerspectiveBank) -> None:
        for mine, theirs in zip(self._parts(), work._parts(), strict=True):
            mine[idx] = theirs

    def shift(self, index: np.ndarray, dxy: np.ndarray, dv: np.ndarray | None = None) -> None:
        """Move rows ``index`` by ``dxy`` (2,) pixels and their velocity by ``dv`` (2,)
        pixels/frame (the camera's image motion)."""
        idx, d, w = self._shifted(index, dxy, dv)
        if idx.size == 0:
            return
        for x in (self._x, self._fx):
            r = x[idx, 3:4]
            x[idx, :2] += d * r
            x[idx, 4:6] += w * r
        self._obs[idx, :2] += d

    def damp(self, index: np.ndarray, factor: float) -> None:
        """Scale the velocities of rows ``index`` by ``factor`` in [0, 1]."""
        self._x[self._damped(index, factor), 4:] *= factor

    def remove(self, index: np.ndarray) -> None:
        """Drop rows ``index`` (int array or (T,) bool mask)."""
        idx = self._rows(index)
        if idx.size:
            self._set(tuple(np.delete(a, idx, axis=0) for a in self._parts()))

    def take(self, index: np.ndarray) -> PerspectiveBank:
        """A new bank of rows ``index``, copied in that order."""
        out = PerspectiveBank(self.config)
        rows = self._rows(index)
        out._set(tuple(a[rows].copy() for a in self._parts()))
        return out

    def extend(self, other: KalmanBank | PerspectiveBank) -> None:
        """Append the rows of ``other`` after this bank's rows."""
        if not isinstance(other, PerspectiveBank):
            raise TypeError("extend: a PerspectiveBank takes the rows of a PerspectiveBank only")
        self._set(
            tuple(
                np.concatenate([a, b]) for a, b in zip(self._parts(), other._parts(), strict=True)
            )
        )

    def observed(self) -> np.ndarray:
        """(T, 4) each row's last measurement as boxes ``x1, y1, x2, y2`` (pixels)."""
        return _to_xyxy(self._obs)

    def xyxy(self) -> np.ndarray:
        """(T, 4) current state as boxes ``x1, y1, x2, y2`` (pixels)."""
        return _to_xyxy(self._boxes(self._x))

    def cxcywh(self) -> np.ndarray:
        """(T, 4) current ``cx, cy, w, h`` (pixels)."""
        return self._boxes(self._x)

    def velocity(self) -> np.ndarray:
        """(T, 4) current ``d(cx, cy, w, h)/frame`` (pixels/frame)."""
        x = self._x
        return (self._jacobian(x) @ x[:, 4:, None])[:, :, 0]

    def motion(self, index: np.ndarray) -> np.ndarray:
        """(K, 2, 2) ``[[cx, cy], [vcx, vcy]]`` of rows ``index`` (pixels, pixels/frame)."""
        idx = self._rows(index)
        return np.stack([self.cxcywh()[idx, :2], self.velocity()[idx, :2]], axis=1)

    def covariance(self) -> np.ndarray:
        """(T, 8, 8) state covariance of ``u, v, a, r`` and their velocities."""
        return self._p.copy()

    def peek(self, steps: int | np.ndarray) -> np.ndarray:
        """(T, 4) boxes extrapolated ``steps`` frames ahead, state unchanged."""
        n = self._frames(steps)
        x = self._x.copy()
        x[:, :4] += n * x[:, 4:]
        self._clamp(x)
        return _to_xyxy(self._boxes(x))

    def copy(self) -> PerspectiveBank:
        """An independent copy (same config object)."""
        out = PerspectiveBank(self.config)
        out._set(tuple(a.copy() for a in self._parts()))
        return out


def motion_bank(config: KalmanConfig | None = None) -> KalmanBank | PerspectiveBank:
    """The filters ``config`` asks for: :class:`PerspectiveBank` where it names a principal
    point, :class:`KalmanBank` otherwise."""
    if config is not None and config.perspective:
        return PerspectiveBank(config)
    return KalmanBank(config)

"""The tracker's parameters, declared once: :class:`TrackerConfig`, :class:`AbductionCosts` and
:class:`KalmanConfig`.

Every field carries its kind, unit and valid range in its dataclass metadata (:func:`param`);
its meaning is the class docstring's ``Attributes:`` entry or the field's ``#:`` comment.
:data:`PARAMETERS` (dotted name -> :class:`Param`) is read from that metadata, :func:`validate`
checks a whole configuration against it generically (``TrackerConfig.__post_init__`` calls it)
and :func:`parameters_table` renders it for ``docs/PARAMETERS.md``. The shipped presets
(``presets/<family>.json``, :meth:`TrackerConfig.for_dataset`) and the parameter document they
share with users' files (:func:`document_params`) are read here too; reading users' files and
``--set`` overrides is :mod:`sensemaking.settings`'s job.
"""

from __future__ import annotations

import dataclasses
import difflib
import inspect
import json
import logging
import math
import numbers
import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from importlib import resources
from os import PathLike
from typing import Any

import numpy as np

from sensemaking.errors import InputError

__all__ = [
    "AbductionCosts",
    "KalmanConfig",
    "TrackerConfig",
    "Param",
    "ParameterError",
    "PARAMETERS",
    "NESTED",
    "MIN_FPS",
    "MAX_FPS",
    "MAX_IMAGE_SIDE",
    "MAX_DIRECTION_FRAMES",
    "FAMILIES",
    "FORMAT",
    "SCENE_PROFILES",
    "param",
    "family_name",
    "preset_params",
    "preset_source",
    "preset_profile",
    "preset_config",
    "document_params",
    "apply_settings",
    "check_value",
    "validate",
    "params_of",
    "parameters_table",
    "CLASS_KEY",
    "CLASS_THRESHOLDS",
    "is_class_key",
    "split_class_key",
]

log = logging.getLogger(__name__)

MIN_FPS, MAX_FPS = 0.01, 1000.0  # frames per second: a frame a 100 s .. a frame a ms
MAX_IMAGE_SIDE = 100_000  # pixels, each side of the field of view
#: the longest span, in frames, a track's direction of motion is read over (``direction_span_s``)
MAX_DIRECTION_FRAMES = 15
#: metadata key of a field's :class:`Param`
_PARAM = "sensemaking.param"


def parse_size(text: str, where: str = "--image-size") -> tuple[int, int]:
    """``WIDTHxHEIGHT`` in pixels, each side in [1, MAX_IMAGE_SIDE]."""
    try:
        w, h = text.lower().split("x")
        size = int(w), int(h)
    except ValueError:
        raise InputError(f"{where} must look like 1242x375, got {text!r}") from None
    if not all(1 <= v <= MAX_IMAGE_SIDE for v in size):
        raise InputError(f"{where}: each side must be 1..{MAX_IMAGE_SIDE} pixels, got {text!r}")
    return size


def check_fps(fps: float, where: str, path: str | PathLike[str] | None = None) -> float:
    """A frame rate in [MIN_FPS, MAX_FPS] frames per second."""
    if not (math.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS):
        raise InputError(
            f"{where} must be a frame rate in [{MIN_FPS:g}, {MAX_FPS:g}] frames per second, "
            f"got {fps!r}",
            path,
        )
    return float(fps)


class ParameterError(InputError):
    """A parameter value of the wrong type, unit or range, or an unknown parameter."""


@dataclass(frozen=True)
class Param:
    """One parameter: ``kind`` is ``bool``, ``int``, ``float`` or ``size`` (width, height);
    values lie in ``[low, high]`` (``low_open``: ``low`` itself excluded); ``optional``: None
    is allowed (meaning: off / not set)."""

    key: str
    kind: str
    unit: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    optional: bool = False

    def range_text(self) -> str:
        if self.kind == "bool":
            return "true / false"
        if self.kind == "classes":
            return (
                "class name -> {start_confidence, min_confidence} (either or both, each any "
                "finite number); {} (none)"
            )
        if self.kind == "size":
            return f"two integers in [{_num(self.low)}, {_num(self.high)}]"
        low = "(" if self.low_open else "["
        lo = "-inf" if self.low is None else _num(self.low)
        hi = "inf" if self.high is None else _num(self.high)
        text = f"{low}{lo}, {hi}]" if self.high is not None else f"{low}{lo}, inf)"
        if self.kind == "int":
            text = f"integer in {text}"
        elif self.low is None and self.high is None:
            text = "any finite number"
        return text + (", or null" if self.optional else "")

    def expect(self) -> str:
        """Unit and range, for error messages."""
        return f"{self.unit}, {self.range_text()}" if self.unit != "-" else self.range_text()

    def check(self, value: Any) -> Any:
        """``value`` if it is valid for this parameter (sizes become tuples), else
        :class:`ParameterError` saying what is expected."""
        key = self.key
        if value is None:
            if self.optional:
                return None
            raise ParameterError(f"{key} must not be null ({self.expect()})")
        if self.kind == "classes":
            return _check_classes(key, value)
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise ParameterError(f"{key} must be true or false, got {value!r}")
            return bool(value)
        if self.kind == "size":
            if (
                not isinstance(value, (tuple, list))
                or len(value) != 2
                or not all(_is_int(v) for v in value)
            ):
                raise ParameterError(
                    f"{key} must be (width, height) in integer pixels, got {value!r}"
                )
            for v in value:
                self._check_range(v)
            return (int(value[0]), int(value[1]))
        if self.kind == "int":
            if not _is_int(value):
                raise ParameterError(f"{key} must be an integer ({self.expect()}), got {value!r}")
            self._check_range(value)
            return value
        # an int is finite however long (float() of one past 1e308 overflows)
        if not _is_real(value) or not (isinstance(value, int) or math.isfinite(float(value))):
            raise ParameterError(f"{key} must be a finite number ({self.expect()}), got {value!r}")
        self._check_range(value)
        return value

    def _check_range(self, value: float) -> None:
        v = value if isinstance(value, int) else float(value)  # ints compare exactly, any size
        too_low = self.low is not None and (v <= self.low if self.low_open else v < self.low)
        too_high = self.high is not None and v > self.high
        if too_low or too_high:
            raise ParameterError(
                f"{self.key} must be in {self.range_text()} ({self.unit}), got {value!r}"
            )


def _num(x: float | None) -> str:
    return "" if x is None else (str(int(x)) if float(x).is_integer() else repr(float(x)))


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


#: the thresholds a class may override (``class_confidence``), each a TrackerConfig field
CLASS_THRESHOLDS: tuple[str, ...] = ("start_confidence", "min_confidence")
#: the parameter holding the per-class overrides, and the head of its dotted keys
CLASS_KEY = "class_confidence"


def _class_name(key: str, name: Any) -> str:
    """The canonical name of a class named in ``key`` (ParameterError if unknown)."""
    from sensemaking.classes import CLASS_IDS, class_id, class_name

    try:
        return class_name(class_id(str(name)))
    except (KeyError, AttributeError):
        raise ParameterError(
            f"{key}: unknown class {name!r} (one of {', '.join(CLASS_IDS)})"
        ) from None


def _check_classes(key: str, value: Any) -> dict[str, dict[str, float]]:
    """``class_confidence``: canonical class name -> {threshold: score}, sorted; ParameterError
    naming the class and threshold otherwise."""
    if not isinstance(value, Mapping):
        raise ParameterError(
            f"{key} must be a table of class name -> {{start_confidence, min_confidence}}, "
            f"got {value!r}"
        )
    out: dict[str, dict[str, float]] = {}
    for name, table in value.items():
        cls = _class_name(key, name)
        if not isinstance(table, Mapping) or not table:
            raise ParameterError(
                f"{key}.{cls} must be a table naming start_confidence and/or min_confidence, "
                f"got {table!r}"
            )
        if cls in out:
            raise ParameterError(f"{key}: class {cls!r} named twice")
        out[cls] = {t: check_class_value(f"{key}.{cls}.{t}", v) for t, v in table.items()}
    return {k: dict(sorted(v.items())) for k, v in sorted(out.items())}


def is_class_key(key: str) -> bool:
    """Whether ``key`` is a dotted per-class threshold, ``class_confidence.CLASS.THRESHOLD``."""
    return key.startswith(CLASS_KEY + ".")


def split_class_key(key: str) -> tuple[str, str]:
    """(canonical class name, threshold) of ``class_confidence.CLASS.THRESHOLD``."""
    parts = key.split(".")
    if len(parts) != 3:
        raise ParameterError(
            f"unknown parameter {key!r} ({CLASS_KEY}.CLASS.THRESHOLD, e.g. "
            f"{CLASS_KEY}.pedestrian.min_confidence)"
        )
    return _class_name(key, parts[1]), parts[2]


def check_class_value(key: str, value: Any) -> float:
    """A per-class threshold ``class_confidence.CLASS.THRESHOLD``: a finite score."""
    threshold = key.rsplit(".", 1)[-1]
    if threshold not in CLASS_THRESHOLDS:
        raise ParameterError(
            f"unknown parameter {key!r} (a class may set {' or '.join(CLASS_THRESHOLDS)})"
        )
    if not _is_real(value) or not math.isfinite(float(value)):
        raise ParameterError(f"{key} must be a finite number ({_SCORE}), got {value!r}")
    return float(value)


def param(
    default: Any,
    kind: str,
    unit: str,
    low: float | None = None,
    high: float | None = None,
    *,
    low_open: bool = False,
    optional: bool = False,
) -> Any:
    """A dataclass field with its :class:`Param` (kind, unit, range) in its metadata; the key
    is the field's dotted name, filled in by :data:`PARAMETERS`."""
    spec = Param("", kind, unit, low, high, low_open, optional)
    if isinstance(default, dict):  # a table: a fresh one per instance
        return field(default_factory=lambda: dict(default), metadata={_PARAM: spec})
    return field(default=default, metadata={_PARAM: spec})


def nested(cls: type) -> Any:
    """A field holding a parameter group (its fields are ``<name>.<field>`` parameters)."""
    return field(default_factory=cls, metadata={_PARAM: None})


_SCORE = "detector score"
_COST = "solver units (1000 = a perfect IoU match)"
_BOX = "fraction of box size"


def _cost(default: int) -> Any:
    return param(default, "int", _COST, 0, 100_000)


@dataclass(frozen=True)
class AbductionCosts:
    """Costs of actions and events, in likelihood units (a perfect IoU match is worth 1000).

    Raising a cost makes the explanation rarer; each is a trade-off between two mistakes.
    """

    #: enters_fov at the border. Higher: fewer new tracks at the border.
    enters: int = _cost(100)
    #: a track starting away from the border. Higher: fewer false tracks, later starts.
    appears: int = _cost(400)
    #: leaves_fov at the border. Higher: tracks linger at the border as missing.
    leaves: int = _cost(100)
    #: a track ending without explanation. Higher: tracks are kept as missing longer.
    lost: int = _cost(600)
    #: a tentative (unconfirmed) track ending: a hypothesis dropped. Higher: young tracks fight
    #: for detections.
    dropped: int = _cost(0)
    #: hides_behind. Higher: fewer occlusion explanations, more missing detections.
    hides: int = _cost(50)
    #: missing_detections. Higher: tracks end instead of waiting.
    missing: int = _cost(250)
    #: per frame a track stays missing. Higher: missing tracks end sooner.
    unseen: int = _cost(20)
    #: ignoring a detection, times its confidence. Higher: more tracks from weak detections.
    ignore: int = _cost(600)
    #: a hidden or missing track seen again (unhides_from_behind or reappears). An unseen track's
    #: prediction is widened, so it fits a detection better than its drifted box deserves; hiding
    #: a visible track costs only ``hides``, and without this cost an unseen track took the
    #: detection of a visible track whose own prediction fits it whenever its widened fit was 0.05
    #: IoU better. Higher: a visible track keeps its detection unless the unseen one fits it
    #: clearly better (by (hides + resumes) / 1000 IoU). Keep it below ``enters`` + 1000 x
    #: ``iou_resume``, else an unseen track at the border loses a weakly fitting detection to a new
    #: track entering there (a new id).
    resumes: int = _cost(100)
    #: an ended track found again within ``revive_s`` (reenters_fov after leaves_fov, returns
    #: after ends), instead of a new track. Keep it below ``enters``: a new track entering at the
    #: border costs that, and the revived track must be the cheaper explanation where it fits.
    #: Higher: a returning object gets a new id where the border makes entering cheap.
    returns: int = _cost(50)
    #: with ``resume_last_seen``: a hidden or missing track resumed by a detection that fits the
    #: box where it was last seen better than its (drifted) prediction, on top of ``resumes``.
    #: Higher: such a track must fit its last seen box clearly better than a visible track's
    #: prediction fits that detection; 0: the better of the two fits is all that counts.
    resumes_seen: int = _cost(100)

    def __post_init__(self) -> None:
        # its own, weaker check (a TrackerConfig checks the ranges): costs are made on their own
        for name, value in asdict(self).items():
            if not isinstance(value, int) or value < 0:
                raise ValueError(f"cost {name} must be a non-negative integer, got {value!r}")


@dataclass
class KalmanConfig:
    """Noise levels of :class:`KalmanBank`, as fractions of the box size (width for ``cx, w``,
    height for ``cy, h``); defaults follow DeepSORT.

    Attributes:
        position_std: process noise std of ``cx, cy, w, h`` per frame. Larger lets the
            filter follow jittery or manoeuvring boxes faster, but makes predictions across
            gaps spread out (looser gating).
        velocity_std: process noise std of the velocities per frame. Larger adapts faster to
            changes of speed (turning, braking); smaller extrapolates occluded objects more
            stiffly. DeepSORT's 1/160 is small: velocity is mostly learned at birth.
        measurement_std: std of detector noise. Larger trusts detections less (smoother,
            laggier boxes); smaller follows each detection closely.
        min_size: lower bound, pixels, on predicted and corrected ``w`` and ``h``: SORT-style
            filters otherwise let a shrinking box collapse to zero or negative size during
            long predictions.
        init_position_std: std of the initial ``cx, cy, w, h`` (DeepSORT: 2 x position_std).
        init_velocity_std: std of the initial velocities, per frame. Large (SORT uses a
            1000x inflated prior) means the second detection of a track sets its velocity
            almost exactly (two-point initialisation), so a constant-velocity box is
            predicted to within a pixel after a few frames; DeepSORT's 10 x velocity_std
            (1/16) instead takes tens of frames to learn a fast object's speed. The cost:
            the first velocity carries about sqrt(2) x the detector noise.
            The tracker sets it from ``TrackerConfig.velocity_prior`` (box sizes per second,
            divided by the frame rate) unless that is None.
        velocity_adapt: rate, per correction, at which each track's velocity noise follows
            its own innovations (covariance matching: it grows while the detections land
            farther from the predictions than the filter expects, shrinks while nearer), from
            ``velocity_std`` within a factor of 16 either way. 0: off, ``velocity_std`` for
            every track. For a camera that sometimes moves and sometimes stands still.
        perspective: filter each box as seen through a pinhole camera (an extended Kalman
            filter of ``(cx - x0) / h``, ``(cy - y0) / h``, ``w / h`` and ``1 / h`` at constant
            velocity, measured in pixels): exact for an object moving at constant velocity
            relative to the camera whether the camera stands or drives forward, where in
            pixels a parked car passed by a driving camera accelerates away from the
            principal point and needs a loose ``velocity_std`` that a standing camera's
            objects are lost by. False: boxes filtered in pixels.
        perspective_x: the principal point's column ``x0`` (the image point a forward-moving
            camera's view expands from), pixels; None: the image's centre (``image_size``).
            Only with ``perspective``; set with ``perspective_y``.
        perspective_y: the principal point's row ``y0`` (the horizon's, for a level camera),
            pixels; None: the image's centre. Only with ``perspective``.
        depth_noise: with ``perspective``, the process noise of ``1 / h`` (an object's depth)
            and the first uncertainty of its rate, as a fraction of the other coordinates':
            a detector's box height jitters more, frame to frame, than the object's depth
            changes, and the pinhole filter moves a box along its ray as its height changes.
            1: as the pixel filter's ``h``; smaller: depth follows the heights more slowly.
    """

    position_std: float = param(1 / 20, "float", _BOX + " per frame", 0.0, 100.0, low_open=True)
    velocity_std: float = param(1 / 160, "float", _BOX + " per frame", 0.0, 100.0, low_open=True)
    measurement_std: float = param(1 / 20, "float", _BOX, 0.0, 100.0, low_open=True)
    init_position_std: float = param(
        2 / 20, "float", _BOX + " per frame", 0.0, 100.0, low_open=True
    )
    init_velocity_std: float = param(1.0, "float", _BOX + " per frame", 0.0, 100.0, low_open=True)
    min_size: float = param(1.0, "float", "pixels", 0.0, 10_000.0, low_open=True)
    velocity_adapt: float = param(0.0, "float", "fraction per correction", 0.0, 1.0)
    perspective: bool = param(False, "bool", "-")
    perspective_x: float | None = param(
        None, "float", "pixels", -MAX_IMAGE_SIDE, MAX_IMAGE_SIDE, optional=True
    )
    perspective_y: float | None = param(
        None, "float", "pixels", -MAX_IMAGE_SIDE, MAX_IMAGE_SIDE, optional=True
    )
    depth_noise: float = param(0.1, "float", "fraction", 0.0, 10.0, low_open=True)

    def __post_init__(self) -> None:
        # its own, weaker check (a TrackerConfig checks the ranges): a bank is made on its own
        for name in (
            "position_std",
            "velocity_std",
            "measurement_std",
            "min_size",
            "init_position_std",
            "init_velocity_std",
            "depth_noise",
        ):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"KalmanConfig.{name} must be finite and > 0, got {value!r}")
        if not 0.0 <= self.velocity_adapt <= 1.0:
            raise ValueError(
                f"KalmanConfig.velocity_adapt must be in [0, 1], got {self.velocity_adapt!r}"
            )
        if (self.perspective_x is None) != (self.perspective_y is None):
            # a relation between two parameters: the user's error, named as they wrote it
            raise ParameterError(
                "kalman.perspective_x and kalman.perspective_y are set together (one is null)"
            )
        for value in (self.perspective_x, self.perspective_y):
            if value is not None and not np.isfinite(value):
                raise ValueError(f"KalmanConfig.perspective_x/_y must be finite, got {value!r}")


@dataclass(frozen=True)
class TrackerConfig:
    """Parameters of :class:`Tracker`. Times are in seconds and turned into frames with ``fps``.

    Attributes:
        abduction: abduce assignments and events with clingo (True) or match by Hungarian IoU
            only (False, the paper's "without abduction"; events are then only starts/ends).
        fps: frame rate of the input (frames per second); converts the time limits below.
        image_size: ``(width, height)`` of the field of view in pixels. Needed to explain
            entering/leaving at the border; without it, tracks only start and end.
        iou_assign: minimum IoU of prediction and detection to continue a visible track.
            Lower: follows fast or erratic motion, but risks id swaps between neighbours.
        iou_resume: minimum IoU to resume a hidden or missing track (its prediction is widened
            by ``resume_growth`` per unseen frame, up to 2x). Lower: more re-identification
            after long gaps, with more wrong re-identifications.
        resume_growth: widening of an unseen track's predicted box per frame, fraction of size.
        new_track_growth: widening of the predicted box of a track seen only once (its velocity
            is unknown), e.g. 1.5 = 50 % larger. Higher: fast objects keep their id from the
            second frame on; too high: neighbours can take each other's young tracks.
        min_confidence: minimum detection score to continue or resume a track (score units of
            the detector). Low-score detections can then keep tracks alive without starting any.
        start_confidence: minimum detection score to start a track. Higher: fewer false tracks.
        class_confidence: per-class ``start_confidence`` and ``min_confidence`` (detector score
            units), e.g. ``{"pedestrian": {"min_confidence": 0.5, "start_confidence": 0.5}}``:
            a detection of a class named here is gated by that class's values, every other
            detection by the two above; a threshold the class does not name is the global one.
            Class names as in ``sensemaking.classes`` (KITTI and MOT spellings). Set one with
            ``--set class_confidence.pedestrian.min_confidence=0.5``, clear them with ``--set
            class_confidence={}``. Detectors score classes differently (a pedestrian is smaller
            and scores lower than a car at the same precision). Empty: one threshold for all.
        max_hidden_s: how long a track hidden behind a known occluder is kept (seconds).
        max_missing_s: how long a track with missing detections (no occluder) is kept (seconds).
        min_hits: detections needed before a new track is reported (1 = at once). During the
            first ``min_hits`` frames of a run tracks are reported at once.
        confirm_confidence: a detection scoring at least this confirms its track at once, whatever
            ``min_hits`` says (detector score units; None: only ``min_hits`` confirms). Strong
            evidence is reported from the first frame, weak evidence must repeat itself.
        hide_cover: fraction of a track's predicted box that a track in front must cover for it to
            hide behind it. Lower: occlusion is abduced more readily.
        keep_cover: fraction of coverage needed to stay hidden (hysteresis; <= hide_cover).
        hide_sure_cover: fraction of a halting track's predicted box its occluder must cover for
            the track to be said hidden (tracking.lp's ``hide_min_cover``); below it its
            detections are missing. At or below ``hide_cover``: every covering occluder counts.
        late_hides: a track already unobserved (missing, or no longer covered by its occluder)
            may be found hiding behind a new occluder (it is then kept as hidden). Off: it
            stays missing.
        late_maybe: such a late hiding is said as the event ``may_hide_behind`` (weaker
            evidence) rather than ``hides_behind``; the track is hidden either way.
        late_hide_cover: with ``late_hides``, the share of its predicted box such a new occluder
            must cover (its predicted box has drifted since it was seen).
        late_confidence: weight of a late hiding's confidence (the event's ``confidence`` is
            the occluder's cover share, times this for a track that was already unobserved).
        depth_clear: how far (fraction of the hidden track's height, or of its depth with 3D
            positions) the occluder must stand in front for its depth order to count as clear.
        depth_confidence: weight of the confidence of a hiding whose depth order is not clear.
        emerge_margin: a hidden track can only unhide where it touches its occluder's box,
            widened by this fraction of the occluder's size on every side. Lower: fewer wrong
            re-identifications in crowds; too low: objects that re-emerge fast get a new id.
        partial_cover: fraction of coverage from which a visible track is partially occluded.
        border_margin: distance to the image border (pixels) counted as "at the border".
        class_aware: only match detections of the track's class.
        inherit_motion: a new track's first prediction moves with the median image velocity of
            the established tracks (seen ``min_hits`` + 2 times or more, visible now; one is
            enough): with a moving camera every object shifts with it, and a new object predicted
            to stand still loses its id to the object behind it (convoys, turning ego vehicle).
            Its own fit at rest counts as well, so an object that does not share the motion is
            still found. False: start at rest, as SORT does.
        confidence_sigmoid: map detector scores through a sigmoid for the costs (for detectors
            that give logits, e.g. PointRCNN). Thresholds stay in the detector's own units.
        likelihood_levels: resolution of likelihoods and confidences in the solver's objective
            (IoU and score are rounded to multiples of 1/levels). Core-guided optimisation slows
            with the number of distinct weights: with full resolution a crowded frame of 100
            tracks took 25 s, with 40 levels 30 ms. Higher: finer preferences, slower worst case.
        decompose: solve the independent components of a frame (objects linked by candidate
            or occlusion facts) separately, each answered by clingo or by the cache of its
            earlier answers to the same facts. Exact for the packaged encoding. None (default):
            on with the packaged encoding, off with a user's encoding or rules (whose rules may
            relate unconnected objects); set True when yours only relate linked objects.
        max_conflicts: deterministic per-component work budget of the solver, in conflicts:
            past it the best answer found so far is used and counted. The same input gives the
            same output on any machine. None: no limit.
        max_solve_ms: per-frame wall-clock budget for solving (milliseconds). Grounding is not
            interrupted but counts against it; past it the best answer found so far is used (or
            Hungarian matching if none) and counted; results then depend on the machine's load.
            None: no limit. A user's rules are bounded per frame by their atom limit.
        velocity_prior: std of a new track's velocity before its detections show it, in box sizes
            per second (width for x, height for y); sets ``kalman.init_velocity_std`` to
            ``velocity_prior / fps``, so one value fits every frame rate. The velocity after the
            second detection is the Bayesian compromise of this prior (mean: rest, or the scene's
            motion with ``inherit_motion``) and the difference of two jittery boxes, weighted by
            their variances. Set it near the spread of true velocities: lower trusts a young
            track's first displacement less (no runaway predictions from detector jitter on
            small boxes), but lets fast objects lag for a few frames (id loss after a gap).
            None: use ``kalman.init_velocity_std`` (per frame) as given.
        weak_confidence: detections scoring from this up to ``min_confidence`` (detector score
            units) are weak evidence: they may continue a confirmed track that was visible in the
            previous frame, seen twice or more and without a candidate detection scoring
            ``min_confidence`` or more, if their IoU with its prediction is at least ``weak_iou``;
            they never resume, start or confirm a track -- ByteTrack's second association (low
            threshold 0.1), strong evidence first as in its cascade. None: off, detections
            under ``min_confidence`` are not used.
        weak_iou: minimum IoU of a weak detection with the prediction of the track it continues
            (ByteTrack's second association: 0.5). Higher: fewer false continuations.
        resume_reupdate: when a hidden or missing track is seen again after k unseen frames,
            re-estimate its motion from the observations at both ends of the gap (OC-SORT's
            observation-centric re-update): the filter returns to its state after the last
            detection and is run over k + 1 virtual detections on the straight line from that
            detection to the new one, instead of one correction from the drifted prediction.
            False: one Kalman correction, as SORT does. Switch (no unit).
        scene_shift: a hidden or missing track moves, each frame, with the image motion of the
            scene that the predictions missed, estimated from the matched boxes: its box centre
            and centre velocity receive the median Kalman correction (pixels, pixels/frame) of
            the established tracks matched in that frame (at least ``SCENE_SHIFT_MIN_TRACKS``),
            as if it had been seen where they were. A moving camera's turn or pitch moves every
            object in the image; an unseen track otherwise keeps the image motion it had when
            last seen. Translation only: the image scaling of forward motion depends on each
            object's depth. Switch (no unit).
        unseen_damping: the fraction of its image velocity (centre and size, pixels / frame)
            that a hidden or missing track keeps per unseen frame, from its second unseen
            frame on, so its prediction slows down and stays near where the object went out of
            sight instead of drifting on a velocity measured from boxes that were shrinking
            behind the occluder (issue 27). In (0, 1]; 1: constant velocity (off), 0.8: after
            10 unseen frames 11 % is left.
        revive_s: a track that ended by leaving the field of view (``leaves_fov``) or by being
            lost (``ends``) stays, for this many seconds after it ended, a candidate that a new
            detection may be explained by (the events ``reenters_fov`` / ``returns``, cost
            ``costs.returns``) instead of a new track: what was said when it ended stays said.
            It must fit: same class, its prediction (widened with the time unseen, as a
            resumed track's) at least ``iou_resume`` IoU with the detection, heights within
            ``revive_height_ratio``, and a detection strong enough to start a track. A revived
            track is confirmed again as a new one is (``min_hits``), its history counting as one
            detection; its event is then reported. The 16 latest ended tracks are kept
            (``track_table.REVIVE_MAX``; issue 27). 0: off.
        revive_hold: where an ended track is looked for: True, the box where it was last seen
            (a car missed at the border comes back where it went); False (measured better), its
            Kalman prediction continued at constant velocity from where it ended. Switch.
        revive_height_ratio: the smaller of the two heights over the larger, at least: a revived
            track's last seen box and the detection (1: equal heights). Lower: admits objects
            that approached or drew away while unseen, and other objects of the class.
        resume_last_seen: a hidden or missing track is also looked for at the box where it was
            last seen, not only at its (widened) prediction (OC-SORT's observation-centric
            recovery, issue 27): a person who stopped behind an occluder, or whose prediction
            drifted while unseen, is resumed where it was last seen. The pair's likelihood is
            the better of the two fits (gated at ``iou_resume``); where the last seen box fits
            better, the fact ``at_last_seen(T,D)`` says so and the resume costs
            ``costs.resumes_seen`` more. Switch (no unit); False: the prediction only.
        lookahead_s: fixed-lag abduction (issue 27): a frame's assignment is decided together
            with the frames that follow it over this time (seconds, ``round(lookahead_s * fps)``
            frames; 0: online). Where a part of the frame is contested (an alternative within
            ``lookahead_margin`` of the optimum), each hypothesis is rolled forward by the
            online tracker and the one cheapest over the window is kept: two crossing people or
            a reappearing object are told apart by the frames after. Outputs, events and
            warnings of a frame are final this much later.
        lookahead_margin: a part of a frame is contested when an alternative explanation costs
            at most this much more than the optimum (solver units). Higher: more frames are
            rolled forward (more work), more chances to undo a swap.
        lookahead_hypotheses: most hypotheses rolled forward per contested frame, the online
            optimum included (N-best pruning). Bounds the work of a frame.
        lookahead_continuity: a continuity term in the look-ahead's choice (issue 27): each
            hypothesis is also charged this much per box height (solver units; 0: off) by which
            the boxes its tracks take over the window stray from their constant-velocity
            extrapolation from before the decided frame (per track and frame, capped at one
            height; summed over the tracks seen in both chains compared). A swap at a crossing
            sends both tracks off their pre-crossing motion, which the encoding's costs, read
            against Kalman filters that followed the swap, may not see.
        lookahead_crowd_budget: the look-ahead's work budget follows the crowd (issue 27):
            work is counted in candidate pairs rather than frames -- a decided frame earns in
            proportion to its problem's size, a check to its part's, a rolled frame a share of
            the frame's (the unchanged parts come from the cache) and the differing parts --
            so the credit is spent on crowded frames, where the crossings are, and a small
            contested part in a crowd costs little. Switch (no unit); False: one unit a frame.
        direction_weight: motion-direction consistency (OC-SORT's observation-centric
            momentum, issue 27): a match costs this much more per half turn between the track's
            direction of motion (from its observation ``direction_span_s`` before its last one
            to the last) and the direction from its observation about ``direction_span_s`` back
            to the detection; a track with a direction left unmatched costs half of
            it (so a match within a quarter turn of the motion is cheaper than none, one against
            it dearer). The angle is rounded to eighths of a turn (45 degrees): four weights.
            Only tracks seen three times or more and moving at least ``direction_min_speed``
            have a direction (solver units; tracking.lp's ``direction_weight``). 0: off.
        direction_min_speed: with ``direction_weight``, how fast a track's last observations
            must move for its direction to count, in box heights per second (the box's last
            observed height): slower tracks' directions are detector jitter.
        direction_span_s: with ``direction_weight``, the time between the observations a
            direction is read from, in frames ``round(direction_span_s * fps)``, at least 1 and
            at most 15 (OC-SORT's delta t is 3 frames: at 30 fps a walking person moves about
            as far in 0.1 s as its box jitters). Longer: less jitter, slower to follow a turn.
        size_weight: size consistency of a resume (issue 27): a hidden or missing track seen
            again costs up to this much more, a quarter of it per tenth by which the heights of
            its last observed box and the detection differ (the smaller over the larger; under
            a tenth: nothing; four tenths or more: all of it): four weights (solver units;
            tracking.lp's ``size_weight``). A person who reappears as a box half as tall is
            more likely someone else. 0: off.
        swap_weight: identity-swap cost (issue 27, crossings traced): a track that takes a
            detection which fits the prediction of a hidden or missing (confirmed) track better
            than its own, while that track stays unseen, costs this much more (solver units;
            tracking.lp's ``swap_weight``). Where one of two crossing people is detected, the
            one whose prediction fits is then seen again rather than the other carried onto
            its box for the price of a resume and a halt. 0: off.
        swap_margin: with ``swap_weight``, how much better (IoU) the unseen track's fit must
            be than the taking track's for the cost to apply (0: any better fit on the
            solver's grid of likelihoods).
        swap_behind: with ``swap_weight``, only a track hidden behind the taking track counts
            (the occluder carried onto the detection of the one it hid); off: any hidden or
            missing track.
        costs: :class:`AbductionCosts`.
        kalman: :class:`~sensemaking.motion.KalmanConfig`.
    """

    abduction: bool = param(True, "bool", "-")
    fps: float = param(10.0, "float", "frames / s", MIN_FPS, MAX_FPS)
    image_size: tuple[int, int] | None = param(
        None, "size", "pixels (width, height)", 1, MAX_IMAGE_SIDE, optional=True
    )
    iou_assign: float = param(0.3, "float", "IoU", 0.0, 1.0)
    iou_resume: float = param(0.1, "float", "IoU", 0.0, 1.0)
    resume_growth: float = param(0.05, "float", "fraction of box size per frame", 0.0, 1.0)
    new_track_growth: float = param(1.5, "float", "factor", 1.0, 10.0)
    min_confidence: float = param(0.0, "float", _SCORE)
    start_confidence: float = param(0.5, "float", _SCORE)
    class_confidence: dict[str, dict[str, float]] = param({}, "classes", _SCORE)
    max_hidden_s: float = param(3.0, "float", "s", 0.0, 3600.0)
    max_missing_s: float = param(1.0, "float", "s", 0.0, 3600.0)
    min_hits: int = param(1, "int", "detections", 1, 1000)
    confirm_confidence: float | None = param(None, "float", _SCORE, optional=True)
    hide_cover: float = param(0.5, "float", "fraction of box area", 0.0, 1.0)
    emerge_margin: float = param(0.25, "float", "fraction of occluder size", 0.0, 10.0)
    keep_cover: float = param(0.2, "float", "fraction of box area (<= hide_cover)", 0.0, 1.0)
    hide_sure_cover: float = param(0.0, "float", "fraction of box area", 0.0, 1.0)
    late_hides: bool = param(True, "bool", "-")
    late_maybe: bool = param(True, "bool", "-")
    late_hide_cover: float = param(0.0, "float", "fraction of box area", 0.0, 1.0)
    late_confidence: float = param(0.5, "float", "factor", 0.0, 1.0)
    depth_clear: float = param(0.15, "float", "fraction of height or depth", 0.0, 1.0)
    depth_confidence: float = param(0.5, "float", "factor", 0.0, 1.0)
    partial_cover: float = param(0.1, "float", "fraction of box area", 0.0, 1.0)
    border_margin: float = param(10.0, "float", "pixels", 0.0, 10_000.0)
    class_aware: bool = param(True, "bool", "-")
    inherit_motion: bool = param(True, "bool", "-")
    confidence_sigmoid: bool = param(False, "bool", "-")
    likelihood_levels: int = param(40, "int", "levels", 1, 1000)
    decompose: bool | None = param(
        None, "bool", "- (null: on for the packaged encoding)", optional=True
    )
    max_conflicts: int | None = param(
        100_000, "int", "solver conflicts per program", 1, 10**9, optional=True
    )
    max_solve_ms: float | None = param(
        None, "float", "ms", 0.0, 3_600_000.0, low_open=True, optional=True
    )
    velocity_prior: float | None = param(
        3.0, "float", "box sizes / s", 0.0, 1000.0, low_open=True, optional=True
    )
    weak_confidence: float | None = param(None, "float", _SCORE, optional=True)
    weak_iou: float = param(0.5, "float", "IoU", 0.0, 1.0)
    resume_reupdate: bool = param(False, "bool", "-")
    scene_shift: bool = param(False, "bool", "-")
    unseen_damping: float = param(
        1.0, "float", "fraction of velocity kept per unseen frame", 0.0, 1.0, low_open=True
    )
    revive_s: float = param(0.0, "float", "s", 0.0, 60.0)
    revive_hold: bool = param(False, "bool", "-")
    revive_height_ratio: float = param(0.7, "float", "ratio of box heights", 0.0, 1.0)
    resume_last_seen: bool = param(False, "bool", "-")
    lookahead_s: float = param(0.0, "float", "s", 0.0, 10.0)
    lookahead_margin: int = param(300, "int", _COST, 0, 100_000)
    lookahead_hypotheses: int = param(3, "int", "hypotheses", 1, 16)
    lookahead_continuity: int = param(0, "int", "solver units per box height", 0, 100_000)
    lookahead_crowd_budget: bool = param(False, "bool", "-")
    direction_weight: int = param(0, "int", _COST, 0, 100_000)
    direction_min_speed: float = param(0.25, "float", "box heights / s", 0.0, 100.0)
    direction_span_s: float = param(0.3, "float", "s", 0.0, 10.0, low_open=True)
    size_weight: int = param(0, "int", _COST, 0, 100_000)
    swap_weight: int = param(0, "int", _COST, 0, 100_000)
    swap_margin: float = param(0.0, "float", "IoU", 0.0, 1.0)
    swap_behind: bool = param(False, "bool", "-")
    costs: AbductionCosts = nested(AbductionCosts)
    kalman: KalmanConfig = nested(KalmanConfig)

    def __post_init__(self) -> None:
        validate(self)  # every field's type, unit and range: its metadata
        # one spelling per class, a copy of the caller's table (the config is frozen)
        object.__setattr__(self, CLASS_KEY, _check_classes(CLASS_KEY, getattr(self, CLASS_KEY)))

    def class_gates(self, class_id: np.ndarray) -> tuple[Any, Any]:
        """(continue, start) score thresholds of detections of classes ``class_id`` (N,):
        ``min_confidence`` and ``start_confidence``, or their ``class_confidence`` overrides.
        Floats when no class overrides them (the common case), else (N,) arrays."""
        low: Any = self.min_confidence
        start: Any = self.start_confidence
        if not self.class_confidence:
            return low, start
        from sensemaking.classes import class_id as id_of

        low = np.full(len(class_id), low, dtype=np.float64)
        start = np.full(len(class_id), start, dtype=np.float64)
        for name, table in self.class_confidence.items():
            rows = class_id == id_of(name)
            low[rows] = table.get("min_confidence", self.min_confidence)
            start[rows] = table.get("start_confidence", self.start_confidence)
        return low, start

    @property
    def max_hidden_frames(self) -> int:
        return max(1, int(round(self.max_hidden_s * self.fps)))

    @property
    def max_missing_frames(self) -> int:
        return max(1, int(round(self.max_missing_s * self.fps)))

    @property
    def revive_frames(self) -> int:
        """``revive_s`` in frames (0: revival off)."""
        return max(1, int(round(self.revive_s * self.fps))) if self.revive_s > 0 else 0

    @property
    def lookahead_frames(self) -> int:
        """Frames of look-ahead k: ``round(lookahead_s * fps)`` (0: online)."""
        return int(round(self.lookahead_s * self.fps))

    @property
    def direction_span_frames(self) -> int:
        """``direction_span_s`` in frames, within 1 .. ``MAX_DIRECTION_FRAMES``."""
        return min(max(1, int(round(self.direction_span_s * self.fps))), MAX_DIRECTION_FRAMES)

    @property
    def kalman_config(self) -> KalmanConfig:
        """``kalman`` with ``velocity_prior`` (if set) as its per-frame ``init_velocity_std``
        and, with ``perspective``, the principal point at the image's centre unless set."""
        kalman = self.kalman
        if kalman.perspective and kalman.perspective_x is None and self.image_size is not None:
            w, h = self.image_size
            kalman = replace(kalman, perspective_x=w / 2.0, perspective_y=h / 2.0)
        if self.velocity_prior is None:
            return kalman
        return replace(kalman, init_velocity_std=self.velocity_prior / self.fps)

    def replace(self, **changes: Any) -> TrackerConfig:
        """A copy with some parameters changed."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def for_dataset(cls, family: str, **changes: Any) -> TrackerConfig:
        """The one parameter set per dataset family (``"kitti"`` or ``"mot"``); see
        docs/PARAMETERS.md."""
        return preset_config(family, **changes)  # presets/<family>.json


def _declared(cls: type, prefix: str = "") -> dict[str, Param]:
    """Dotted name -> :class:`Param` of every field of ``cls`` with one, groups expanded."""
    out: dict[str, Param] = {}
    for f in dataclasses.fields(cls):
        if _PARAM not in f.metadata:
            continue
        spec = f.metadata[_PARAM]
        if spec is None:  # a group: its own fields, named <name>.<field>
            kind = f.default_factory
            out.update(_declared(kind, f"{prefix}{f.name}."))  # type: ignore[arg-type]
        else:
            out[prefix + f.name] = replace(spec, key=prefix + f.name)
    return out


#: dotted parameter name -> :class:`Param`, in declaration order
PARAMETERS: dict[str, Param] = _declared(TrackerConfig)
#: the fields of :class:`TrackerConfig` that hold parameter groups
NESTED: tuple[str, ...] = tuple(
    f.name for f in dataclasses.fields(TrackerConfig) if f.metadata.get(_PARAM, 0) is None
)


#: the dataset families with a shipped preset (``presets/<family>.json``)
FAMILIES: tuple[str, ...] = ("kitti", "mot")
#: other names accepted for a family
_FAMILY_ALIASES = {
    "mot17": "mot",
    "mot15": "mot",
    "mot16": "mot",
    "mot20": "mot",
    "motchallenge": "mot",
}
#: the ``format`` tag of parameter files this version reads and writes
FORMAT = "sensemaking-params/1"
_FILE_KEYS = {"format", "base", "source", "params", "profile"}
#: scene profiles: a camera on an ego vehicle, or a standing / handheld camera without one
SCENE_PROFILES: tuple[str, ...] = ("driving", "fixed")


# -- families ------------------------------------------------------------------------------------
def family_name(family: str) -> str:
    """The canonical family (``kitti`` / ``mot``) of a family or benchmark-rules name."""
    key = str(family).strip().lower()
    key = _FAMILY_ALIASES.get(key, key)
    if key not in FAMILIES:
        raise ParameterError(f"unknown dataset family {family!r} (kitti or mot)")
    return key


# -- presets and parameter documents ------------------------------------------------------------
def _preset_document(family: str) -> dict[str, Any]:
    name = family_name(family)
    ref = resources.files("sensemaking") / "presets" / f"{name}.json"
    return json.loads(ref.read_text(encoding="utf-8"))


def preset_params(family: str) -> dict[str, Any]:
    """The shipped preset of a family as dotted key -> value (only the values it changes)."""
    name = family_name(family)
    doc = _preset_document(name)
    return document_params(doc, f"presets/{name}.json")


def preset_source(family: str) -> str:
    """Where a preset's values came from (its ``source`` text)."""
    return str(_preset_document(family).get("source", ""))


def preset_profile(family: str) -> str:
    """The scene profile a family's preset names (``driving`` when it names none)."""
    return str(_preset_document(family).get("profile", "driving"))


def _flatten(params: Mapping[str, Any], where: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in params.items():
        if key in NESTED and isinstance(value, Mapping):
            for sub, v in value.items():
                out[f"{key}.{sub}"] = v
        else:
            out[str(key)] = value
    return out


def document_params(doc: Any, where: str) -> dict[str, Any]:
    """Validated dotted params of a parameter document (``where`` names it in errors)."""
    if not isinstance(doc, Mapping):
        raise ParameterError("a parameter file must hold an object with a 'params' table", where)
    unknown = sorted(set(doc) - _FILE_KEYS)
    if unknown:
        raise ParameterError(
            f"unknown key {unknown[0]!r} (expected {', '.join(sorted(_FILE_KEYS))})", where
        )
    fmt = doc.get("format", FORMAT)
    if fmt != FORMAT:
        raise ParameterError(f"format {fmt!r} is not {FORMAT!r}", where)
    profile = doc.get("profile", SCENE_PROFILES[0])
    if profile not in SCENE_PROFILES:
        raise ParameterError(
            f"profile {profile!r} is not one of {', '.join(SCENE_PROFILES)}", where
        )
    params = doc.get("params", {})
    if not isinstance(params, Mapping):
        raise ParameterError("'params' must be a table of parameter: value", where)
    out: dict[str, Any] = {}
    for key, value in _flatten(params, where).items():
        if key in NESTED:
            raise ParameterError(
                f"{key}: expected a table of {key}.NAME values, got {value!r}", where
            )
        if key not in PARAMETERS and not is_class_key(key):
            raise ParameterError(f"params: unknown parameter {key!r}{suggest(key)}", where)
        if isinstance(value, list) and key in PARAMETERS and PARAMETERS[key].kind == "size":
            value = tuple(value)
        try:
            out[key] = check_value(key, value)
        except ParameterError as exc:
            raise ParameterError(f"params.{exc.problem}", where) from None
    return out


def apply_settings(
    config: TrackerConfig, params: Mapping[str, Any], where: str | None = None
) -> TrackerConfig:
    """``config`` with dotted ``params`` applied (``costs.x`` / ``kalman.x`` reach the nested
    settings), validated as a whole."""
    top: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {}
    per_class: dict[str, dict[str, float]] = {}
    for key, value in params.items():
        try:
            value = check_value(key, value)
            if is_class_key(key):  # one threshold of one class, over the table so far
                cls, threshold = split_class_key(key)
                per_class.setdefault(cls, {})[threshold] = value
                continue
        except ParameterError as exc:
            raise ParameterError(exc.problem, where) from None
        head, _, tail = key.partition(".")
        if tail:
            nested.setdefault(head, {})[tail] = value
        else:
            top[key] = value
    if per_class:
        table = {k: dict(v) for k, v in top.get(CLASS_KEY, getattr(config, CLASS_KEY)).items()}
        for cls, changes in per_class.items():
            table.setdefault(cls, {}).update(changes)
        top[CLASS_KEY] = table
    try:
        for head, changes in nested.items():  # a group checks the relations of its fields
            top[head] = dataclasses.replace(getattr(config, head), **changes)
        return dataclasses.replace(config, **top)
    except ParameterError as exc:
        raise ParameterError(exc.problem, where) from None
    except (TypeError, ValueError) as exc:
        raise ParameterError(str(exc), where) from None


def _default_config() -> TrackerConfig:
    return TrackerConfig()


def preset_config(family: str, **changes: Any) -> TrackerConfig:
    """The family's preset (``presets/<family>.json``) over the defaults, then ``changes``
    (keyword names; ``costs`` / ``kalman`` as objects, as ``TrackerConfig`` takes them)."""
    config = apply_settings(
        _default_config(), preset_params(family), f"presets/{family_name(family)}.json"
    )
    return dataclasses.replace(config, **changes) if changes else config


def suggest(key: str) -> str:
    """`` (did you mean 'x'?)`` for an unknown parameter name close to a known one, else ``""``."""
    close = difflib.get_close_matches(key, list(PARAMETERS), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def check_value(key: str, value: Any) -> Any:
    """``value`` if it is valid for parameter ``key`` (sizes become tuples), else
    :class:`ParameterError` saying what is expected."""
    p = PARAMETERS.get(key)
    if p is None:
        if is_class_key(key):  # class_confidence.CLASS.THRESHOLD
            cls, threshold = split_class_key(key)
            return check_class_value(f"{CLASS_KEY}.{cls}.{threshold}", value)
        raise ParameterError(f"unknown parameter {key!r}{suggest(key)}")
    return p.check(value)


def params_of(config: Any) -> dict[str, Any]:
    """Every parameter of a ``TrackerConfig`` as dotted key -> value."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if f.name in NESTED and dataclasses.is_dataclass(value):
            for g in dataclasses.fields(value):
                out[f"{f.name}.{g.name}"] = getattr(value, g.name)
        else:
            out[f.name] = value
    return out


def validate(config: Any) -> None:
    """Check every parameter of a ``TrackerConfig`` against its metadata (:data:`PARAMETERS`)
    and the relations between them. Raises :class:`ParameterError` (a ``ValueError``) naming
    the first bad one. Fields without metadata are left to their own class."""
    for key, value in params_of(config).items():
        if key in PARAMETERS:
            check_value(key, value)
        else:
            log.debug("parameter %s has no Param in its field metadata", key)
    if config.keep_cover > config.hide_cover:
        raise ParameterError(
            f"keep_cover ({config.keep_cover}) must not exceed hide_cover ({config.hide_cover})"
        )
    k = config.kalman
    if k.perspective and k.perspective_x is None and config.image_size is None:
        raise ParameterError(
            "kalman.perspective needs the principal point: kalman.perspective_x and "
            "kalman.perspective_y, or image_size (its centre)"
        )
    if k.perspective and k.velocity_adapt > 0:
        raise ParameterError("kalman.velocity_adapt works with the pixel filter only")


# -- documentation ------------------------------------------------------------------------------
def _docstring_meanings(cls: type) -> dict[str, str]:
    """``name: text`` entries of a class docstring's ``Attributes:`` section."""
    doc = inspect.getdoc(cls) or ""
    out: dict[str, str] = {}
    section = doc.split("Attributes:", 1)[1] if "Attributes:" in doc else ""
    current: str | None = None
    for line in section.splitlines():
        m = re.match(r"^    (\w+): (.*)$", line)
        if m:
            current = m.group(1)
            out[current] = m.group(2).strip()
        elif current and line.startswith("        "):
            out[current] += " " + line.strip()
        elif line.strip() == "":
            continue
        else:
            current = None
    return out


def _comment_meanings(cls: type) -> dict[str, str]:
    """``#:`` comments of a dataclass's fields (on the line, or in the lines above)."""
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):  # pragma: no cover - source not shipped
        return {}
    out: dict[str, str] = {}
    above: list[str] = []
    for line in source.splitlines():
        s = line.strip()
        if s.startswith("#:"):
            above.append(s[2:].strip())
            continue
        m = re.match(r"^(\w+): [^=]+=[^#]*(?:#:\s*(.*))?$", s)
        if m:
            text = " ".join(above + ([m.group(2)] if m.group(2) else []))
            out[m.group(1)] = text.strip()
        above = []
    return out


def meanings() -> dict[str, str]:
    """Dotted parameter name -> its meaning, read from the docstrings and field comments of
    the configuration classes."""
    config = TrackerConfig()
    out = dict(_docstring_meanings(TrackerConfig))
    for name in NESTED:
        cls = type(getattr(config, name))
        found = _docstring_meanings(cls) or _comment_meanings(cls)
        if not found or len(found) < len(dataclasses.fields(cls)) // 2:
            found = {**_comment_meanings(cls), **found}
        for k, v in found.items():
            out[f"{name}.{k}"] = v
    return out


def parameters_table() -> str:
    """The markdown table of every parameter: name, unit, valid range, default, meaning."""
    defaults = params_of(TrackerConfig())
    texts = meanings()
    lines = ["| parameter | unit | valid values | default | meaning |", "|---|---|---|---|---|"]
    for key, p in PARAMETERS.items():
        default = defaults.get(key)
        text = texts.get(key, "").replace("|", "\\|")
        lines.append(
            f"| `{key}` | {p.unit} | {p.range_text()} | {_fmt_default(default)} | {text} |"
        )
    return "\n".join(lines)


def _fmt_default(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple):
        return "x".join(str(v) for v in value)
    return str(value)

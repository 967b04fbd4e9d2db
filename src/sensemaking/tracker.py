"""The online tracker: ``Tracker.update(detections) -> FrameResult`` (Algorithm 1 of the paper).

Per frame: Kalman prediction of every track, IoU of predictions and detections as the matching
likelihood, gating in numpy, then clingo abduces the assignment together with the events that
explain it (``abduction=True``), or plain Hungarian IoU matching does the assignment
(``abduction=False``: the paper's "without abduction", for ablations).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from sensemaking import settings
from sensemaking.abduction.components import ComponentSolver
from sensemaking.abduction.problem import VISIBILITY_VALUES, FrameProblem
from sensemaking.abduction.solver import AbductionSolver, Answer, Det, read_encoding
from sensemaking.detections import Detections, check_frame_number, validate_detections
from sensemaking.geometry import (
    box_area,
    cut_by_border,
    in_front,
    intersection,
    iou,
    iou_from_intersection,
    safe_ratio,
)
from sensemaking.motion import KalmanConfig
from sensemaking.results import Event, FrameAbduction, FrameResult, TrackState
from sensemaking.track_table import TrackTable

__all__ = ["TrackerConfig", "Tracker", "FrameResult", "Event", "TrackState"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class AbductionCosts:
    """Costs of actions and events, in likelihood units (a perfect IoU match is worth 1000).

    Raising a cost makes the explanation rarer; each is a trade-off between two mistakes.
    """

    enters: int = 100  #: enters_fov at the border. Higher: fewer new tracks at the border.
    #: a track starting away from the border. Higher: fewer false tracks, later starts.
    appears: int = 400
    leaves: int = 100  #: leaves_fov at the border. Higher: tracks linger at the border as missing.
    #: a track ending without explanation. Higher: tracks are kept as missing longer.
    lost: int = 600
    #: a tentative (unconfirmed) track ending: a hypothesis dropped. Higher: young tracks fight
    #: for detections.
    dropped: int = 0
    #: hides_behind. Higher: fewer occlusion explanations, more missing detections.
    hides: int = 50
    missing: int = 250  #: missing_detections. Higher: tracks end instead of waiting.
    unseen: int = 20  #: per frame a track stays missing. Higher: missing tracks end sooner.
    #: ignoring a detection, times its confidence. Higher: more tracks from weak detections.
    ignore: int = 600
    #: a hidden or missing track seen again (unhides_from_behind or reappears). An unseen track's
    #: prediction is widened, so it fits a detection better than its drifted box deserves; hiding
    #: a visible track costs only ``hides``, and without this cost an unseen track took the
    #: detection of a visible track whose own prediction fits it whenever its widened fit was 0.05
    #: IoU better. Higher: a visible track keeps its detection unless the unseen one fits it
    #: clearly better (by (hides + resumes) / 1000 IoU). Keep it below ``enters`` + 1000 x
    #: ``iou_resume``, else an unseen track at the border loses a weakly fitting detection to a new
    #: track entering there (a new id).
    resumes: int = 100

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not isinstance(value, int) or value < 0:
                raise ValueError(f"cost {name} must be a non-negative integer, got {value!r}")


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
        max_solve_ms: per-frame wall-clock budget for grounding + solving (milliseconds). Past
            it the best answer found so far is used (or Hungarian matching if none) and counted;
            results then depend on the machine's load. None: no limit.
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
        costs: :class:`AbductionCosts`.
        kalman: :class:`~sensemaking.motion.KalmanConfig`.
    """

    abduction: bool = True
    fps: float = 10.0
    image_size: tuple[int, int] | None = None
    iou_assign: float = 0.3
    iou_resume: float = 0.1
    resume_growth: float = 0.05
    new_track_growth: float = 1.5
    min_confidence: float = 0.0
    start_confidence: float = 0.5
    max_hidden_s: float = 3.0
    max_missing_s: float = 1.0
    min_hits: int = 1
    confirm_confidence: float | None = None
    hide_cover: float = 0.5
    emerge_margin: float = 0.25
    keep_cover: float = 0.2
    partial_cover: float = 0.1
    border_margin: float = 10.0
    class_aware: bool = True
    inherit_motion: bool = True
    confidence_sigmoid: bool = False
    likelihood_levels: int = 40
    decompose: bool | None = None
    max_conflicts: int | None = 100_000
    max_solve_ms: float | None = None
    velocity_prior: float | None = 3.0
    weak_confidence: float | None = None
    weak_iou: float = 0.5
    resume_reupdate: bool = False
    scene_shift: bool = False
    unseen_damping: float = 1.0
    costs: AbductionCosts = field(default_factory=AbductionCosts)
    kalman: KalmanConfig = field(default_factory=KalmanConfig)

    def __post_init__(self) -> None:
        settings.validate(self)  # every parameter's type, unit and range: sensemaking.settings

    @property
    def max_hidden_frames(self) -> int:
        return max(1, int(round(self.max_hidden_s * self.fps)))

    @property
    def max_missing_frames(self) -> int:
        return max(1, int(round(self.max_missing_s * self.fps)))

    @property
    def kalman_config(self) -> KalmanConfig:
        """``kalman`` with ``velocity_prior`` (if set) as its per-frame ``init_velocity_std``."""
        if self.velocity_prior is None:
            return self.kalman
        return replace(self.kalman, init_velocity_std=self.velocity_prior / self.fps)

    def replace(self, **changes: Any) -> TrackerConfig:
        """A copy with some parameters changed."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def for_dataset(cls, family: str, **changes: Any) -> TrackerConfig:
        """The one parameter set per dataset family (``"kitti"`` or ``"mot"``); see
        docs/PARAMETERS.md."""
        return settings.preset_config(family, **changes)  # presets/<family>.json


#: ``scene_shift`` needs at least this many matched established tracks: a median of three
#: outvotes one object that manoeuvres on its own
SCENE_SHIFT_MIN_TRACKS = 3

_HIDDEN = int(TrackState.HIDDEN)  # as a plain int: numpy compares it faster than the enum


class Tracker:
    """Online multi-object tracker with abductive explanations.

    ``update(detections)`` once per frame, in order; ``reset()`` before a new sequence.
    """

    def __init__(
        self,
        config: TrackerConfig | None = None,
        *,
        encoding: str | Path | None = None,
        rules: str | Path | Sequence[str | Path] = (),
        **overrides: Any,
    ):
        """Args:
        config: the parameters (default :class:`TrackerConfig`); ``overrides`` change some.
        encoding: an encoding (a ``.lp`` path or its text) that replaces the packaged
            ``tracking.lp``; it reads the same facts and shows the same atoms.
        rules: more rules (``.lp`` paths or text) added to the encoding, e.g. your own
            events: ``occurs(stops(T)) :- track(T), speed(T,S), S < 5.`` is reported as an
            event ``stops`` on every frame where it holds (see ``tracking.lp``'s facts).
        """
        self.config = (
            replace(config or TrackerConfig(), **overrides)
            if overrides
            else (config or TrackerConfig())
        )
        c = self.config
        extra = [rules] if isinstance(rules, (str, Path)) else list(rules)
        solver = AbductionSolver(
            constants={
                # thresholds on the likelihood grid, rounded down so that every pair the numpy
                # gate admits also passes the encoding's constraint
                "iou_assign": self._quantize(np.array([c.iou_assign]), np.floor)[0],
                "iou_resume": self._quantize(np.array([c.iou_resume]), np.floor)[0],
                # confidence gates are applied in numpy in the detector's own units: detections
                # too weak to start a track get confidence 0 in the facts, all others >= 1
                "conf_assign": 0,
                "conf_start": 1,
                "class_aware": int(c.class_aware),
                # every event cost is tracking.lp's #const cost_<name>
                **{f"cost_{name}": value for name, value in asdict(c.costs).items()},
            },
            encoding=None if encoding is None else read_encoding(encoding),
            rules=[read_encoding(r) for r in extra],
            max_conflicts=c.max_conflicts,
        )
        packaged = encoding is None and not extra
        decompose = packaged if c.decompose is None else c.decompose
        grid = self._quantize(np.linspace(0.0, 1.0, c.likelihood_levels + 1)).tolist()
        self._solver = ComponentSolver(solver, decompose=decompose, numbers=grid)
        self.reset()

    def _quantize(self, x: np.ndarray, rounding=np.rint) -> np.ndarray:
        """Values in [0, 1] -> integers 0..1000 on a grid of ``likelihood_levels`` steps."""
        return _quantize(x, self.config.likelihood_levels, rounding)

    # -- state ------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget every track; the next update is a first frame. Ids start again at 1."""
        self._tracks = TrackTable(self.config.kalman_config)
        self._pending: dict[int, Event] = {}  # start events of tentative tracks
        self._next_id = 1
        self._frames_seen = 0
        self._last_frame: int | None = None
        self.stats = {"frames": 0, "timed_out": 0, "fallback": 0, "solve_ms": 0.0}

    @property
    def n_tracks(self) -> int:
        """Live tracks (visible, hidden and missing, confirmed or not)."""
        return int(self._tracks.id.shape[0])

    # -- the loop ---------------------------------------------------------------------------
    def update(self, detections: Any, frame: int | None = None) -> FrameResult:
        """Process one frame of detections; return every live confirmed track and the events.

        Args:
            detections: :class:`Detections` of one frame (or anything ``adapters.as_detections``
                takes: supervision Detections, ultralytics results, (N, 4|5|6) arrays).
            frame: the frame number; default: the detections' frame column, else last + 1.
        """
        # checked before any state changes: a refused frame leaves the tracker as it was
        dets = validate_detections(_coerce(detections), self.config.image_size)
        if frame is not None:
            frame = check_frame_number(frame)
        if frame is None:
            if len(dets):
                frame = int(dets.frame[0])
            else:
                frame = 0 if self._last_frame is None else self._last_frame + 1
        if len(dets) and (dets.frame != frame).any():
            dets = dets.with_(frame=np.full(len(dets), frame))
        if self._last_frame is not None and frame <= self._last_frame:
            raise ValueError(f"frames must increase: got frame {frame} after {self._last_frame}")
        self._last_frame = frame
        self._frames_seen += 1
        self.stats["frames"] += 1

        if self.config.unseen_damping < 1.0 and (self._tracks.unseen > 0).any():
            # issue 27: an unseen track's image velocity fades (unseen_damping)
            self._tracks.kf.damp(self._tracks.unseen > 0, self.config.unseen_damping)
        pred = self._tracks.kf.predict(1) if len(self._tracks) else np.zeros((0, 4))
        t0 = time.perf_counter()
        self._frame_problem: FrameProblem | None = None
        if self.config.abduction:
            answer, timed_out = self._abduce(pred, dets)
        else:
            answer, timed_out = self._hungarian(pred, dets), False
        solve_ms = (time.perf_counter() - t0) * 1000.0
        self.stats["solve_ms"] += solve_ms
        events, matched = self._apply(answer, dets, frame)
        abduction = None
        if self._frame_problem is not None:
            started = set(answer.start)
            new_tracks = {row: tid for tid, row in matched.items() if row in started}
            abduction = FrameAbduction(self._frame_problem, new_tracks, self._solver.solver)
        return FrameResult(
            frame=frame,
            tracks=self._output(dets, matched, frame),
            events=events,
            solve_ms=solve_ms,
            timed_out=timed_out,
            abduction=abduction,
        )

    # -- association --------------------------------------------------------------------------
    def _likelihood(self, pred: np.ndarray, dets: Detections) -> np.ndarray:
        """(T, D) IoU of (widened, for unseen tracks) predictions and detections, 0 where gated."""
        return self._gate(pred, dets)[0]

    def _uncertain(
        self, pred: np.ndarray
    ) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
        """(T,) mask of the tracks whose motion is uncertain -- unseen (more with time) or seen
        once (velocity unknown), gated at the lower ``iou_resume`` -- and the extra boxes whose
        fit counts for them, as ``(rows, boxes)`` parts: their widened predictions and, for
        young tracks, the prediction at rest and its widening."""
        c = self.config
        young = self._tracks.hits <= 1
        unseen = (self._tracks.unseen > 0) | young
        parts: list[tuple[np.ndarray, np.ndarray]] = []
        if unseen.any():
            grow = np.minimum(1.0 + c.resume_growth * self._tracks.unseen, 2.0)
            grow = np.where(young, np.maximum(grow, c.new_track_growth), grow)
            # the widened box admits far matches; an exact fit to the plain prediction still wins
            parts.append((unseen, _widen(pred[unseen], grow[unseen])))
            if c.inherit_motion and young.any():
                # a young track moved with the scene's motion (inherit_motion); in case its own
                # motion differs, a fit at rest counts as well
                v = self._tracks.kf.velocity()[young, :2]
                rest = pred[young] - np.concatenate([v, v], axis=1)
                parts += [(young, rest), (young, _widen(rest, grow[young]))]
        return unseen, parts

    def _gate(
        self,
        pred: np.ndarray,
        dets: Detections,
        plain: np.ndarray | None = None,
        uncertain: tuple[np.ndarray, list] | None = None,
        extra: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_likelihood` and its values on the solver's grid (``_quantize``). A caller that
        has them already passes ``plain`` = ``iou(pred, dets.xyxy)``, ``uncertain`` =
        ``self._uncertain(pred)`` and ``extra`` = the iou of its parts' boxes (stacked) with the
        detections."""
        c = self.config
        if len(pred) == 0 or len(dets) == 0:
            empty = np.zeros((len(pred), len(dets)))
            return empty, empty.astype(np.int64)
        unseen, parts = self._uncertain(pred) if uncertain is None else uncertain
        lik = iou(pred, dets.xyxy) if plain is None else plain.copy()
        if parts:
            if extra is None:  # one iou call for all parts (iou is elementwise in its rows)
                extra = iou(np.concatenate([b for _, b in parts]), dets.xyxy)
            start = 0
            for rows, boxes in parts:  # max is exact and order-free: as one max per part
                lik[rows] = np.maximum(lik[rows], extra[start : start + len(boxes)])
                start += len(boxes)
        same = (
            self._tracks.cls[:, None] == dets.class_id[None, :]
            if c.class_aware
            else np.ones((len(pred), len(dets)), dtype=bool)
        )
        resume, assign = self._thresholds(c.iou_resume, c.iou_assign)
        # gate on the solver's likelihood grid against its (floored) thresholds, so that the gate
        # admits exactly the pairs the encoding's constraints allow (gating is only an
        # optimisation): comparing the raw IoU instead dropped pairs that round up to the threshold
        q = self._quantize(lik)
        fits = same & (q >= np.where(unseen, resume, assign)[:, None])
        ok = fits & (dets.confidence >= c.min_confidence)[None, :]
        if c.weak_confidence is not None:
            # ByteTrack's second association: a weak detection continues a confirmed track seen
            # last frame (velocity known) that it fits closely and that no detection strong
            # enough to continue tracks could continue (strong evidence first, as its cascade)
            weak = (dets.confidence >= c.weak_confidence) & (dets.confidence < c.min_confidence)
            if weak.any():
                settled = ~unseen & self._tracks.confirmed & ~ok.any(axis=1)
                ok = ok | (fits & weak[None, :] & settled[:, None] & (lik >= c.weak_iou))
        return np.where(ok, lik, 0.0), q

    def _thresholds(self, *iou: float) -> tuple[int, ...]:
        """IoU thresholds on the solver's grid, rounded down."""
        return _floored_grid(self.config.likelihood_levels, iou)

    def _scaled_confidence(self, conf: np.ndarray) -> np.ndarray:
        if self.config.confidence_sigmoid:
            conf = 1.0 / (1.0 + np.exp(-conf))
        return self._quantize(conf)

    def _borders(
        self, boxes: np.ndarray, area: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(at the border, mostly outside) for (N, 4) boxes; all False without an image size.
        ``area``: ``geometry.box_area(boxes)`` if the caller has it already."""
        n = len(boxes)
        if self.config.image_size is None or n == 0:
            return np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
        m, image, far = _image_limits(self.config.image_size, self.config.border_margin)
        # x1 <= m or y1 <= m or x2 >= w - m or y2 >= h - m
        near = (boxes[:, :2] <= m) | (boxes[:, 2:] >= far)  # (N, 2): x side, y side
        at = near[:, 0] | near[:, 1]
        area = box_area(boxes) if area is None else area
        inside = safe_ratio(
            intersection(boxes, image)[:, 0], area
        )  # geometry.coverage(boxes, image)
        return at, inside < 0.05  # (almost) nothing left in view; detections may stick out far

    def _problem(self, pred: np.ndarray, dets: Detections) -> FrameProblem:
        c = self.config
        n, nd, dxy = len(pred), len(dets), dets.xyxy
        nb = n + nd
        # one intersection of every box (predictions, then detections, then the uncertain
        # tracks' extra boxes, see _uncertain) with the predictions and detections, from which
        # the iou and coverage of its blocks follow
        uncertain = self._uncertain(pred) if n and nd else None
        if uncertain is not None:
            boxes = np.concatenate([pred, dxy] + [b for _, b in uncertain[1]])
        else:
            boxes = pred if n else dxy
        inter = intersection(boxes, boxes[:nb])
        area = box_area(boxes)
        covered = safe_ratio(inter[:nb], area[:nb, None])  # geometry.coverage: i covered by j
        plain = extra = None
        if n and nd:
            # iou of every box with the detections (rows n..nb, detections with themselves,
            # are not used)
            fit = iou_from_intersection(inter[:, n:nb], area, area[n:nb])
            plain, extra = fit[:n], fit[nb:]
        # coverage by boxes in front only (geometry.in_front: 3D depth where both have one, else
        # the lower bottom of a box not cut by the border; never a box by itself)
        depth = np.concatenate([self._tracks.depth, dets.depth])
        cut = cut_by_border(boxes[:nb], c.image_size, c.border_margin)
        front = in_front(boxes[:nb], depth, cut)
        in_front_cov = np.where(front.T, covered, 0.0)
        lik, qlik = self._gate(pred, dets, plain, uncertain, extra)
        ti, dj = np.nonzero(lik > 0)
        cand = _int_columns(ti, dj, qlik[ti, dj])
        cand_exact = lik[ti, dj]
        at_all, outside_all = self._borders(boxes[:nb], area[:nb])
        at_border, outside, det_border = at_all[:n], outside_all[:n], at_all[n:]
        start_ok = dets.confidence >= c.start_confidence
        covers = keeps = fits = np.zeros((0, 2), dtype=np.int64)
        covers_exact = np.zeros(0)
        overlapped = np.zeros(n, dtype=bool)
        if n > 1:
            overlapped = in_front_cov[:n, :n].max(axis=1) >= c.partial_cover
        if n and nd:
            # an occluder is visible: measure coverage with its detection, not its prediction
            dcov = in_front_cov[:n, n:]
            back, dj = np.nonzero(dcov >= c.hide_cover)
            covers = _int_columns(dj, back)
            covers_exact = dcov[back, dj]
            # covering detections that fit the track as its own observation would (fits/2)
            own = qlik[back, dj] >= self._thresholds(c.iou_resume)[0]
            if c.class_aware:
                own &= self._tracks.cls[back] == dets.class_id[dj]
            fits = _int_columns(back[own], dj[own])
            if (self._tracks.occluder >= 0).any():
                back, dj = np.nonzero(
                    (dcov >= c.keep_cover) & (self._tracks.occluder >= 0)[:, None]
                )
                keeps = _int_columns(dj, back)
        det_overlapped = np.zeros(nd, dtype=bool)
        if nd > 1:
            det_overlapped = in_front_cov[n:, n:].max(axis=1) >= c.partial_cover
        expired = self._expired()
        hid = np.flatnonzero((self._tracks.state == _HIDDEN) & (self._tracks.occluder >= 0))
        emerges = self._emerges(pred, dets, hid, lik)
        det_conf = self._scaled_confidence(dets.confidence)
        # detections too weak to start a track: still usable to continue one (conf gate in numpy)
        det_conf_fact = np.where(start_ok, np.maximum(det_conf, 1), 0)
        active = self._tracks.unseen == 0
        return FrameProblem(
            track_id=self._tracks.id,
            active=active,
            tentative=~self._tracks.confirmed,
            expired=expired,
            outside=outside,
            at_border=at_border,
            overlapped=overlapped,
            track_class=self._tracks.cls,
            uncertain=(self._tracks.hits <= 1) & active,
            det_conf=det_conf_fact,
            det_class=dets.class_id,
            det_border=det_border & start_ok,
            det_overlapped=det_overlapped,
            cand=cand,
            covers=covers,
            fits=fits,
            keeps_covering=keeps,
            hidden_by=_int_columns(self._tracks.id[hid], self._tracks.occluder[hid]),
            emerges=emerges,
            visibility=self._tracks.vis,
            first_frame=self._frames_seen == 1,
            cand_exact=cand_exact,
            covers_exact=covers_exact,
            speed=self._speed() if "speed" in self._solver.solver.uses else None,
            cut=cut[:n],
        )

    def _speed(self) -> np.ndarray:
        """(T,) predicted speed of each track's box centre, pixels per second (``speed/2``)."""
        v = self._tracks.kf.velocity()[:, :2] if len(self._tracks) else np.zeros((0, 2))
        return np.rint(np.hypot(v[:, 0], v[:, 1]) * self.config.fps).astype(np.int64)

    def _expired(self) -> np.ndarray:
        """(T,) bool: unseen tracks that would pass their time limit (hidden or missing) now."""
        c = self.config
        unseen = self._tracks.unseen > 0
        if not unseen.any():
            return unseen  # all False: every track was seen last frame
        limit = np.where(self._tracks.state == _HIDDEN, c.max_hidden_frames, c.max_missing_frames)
        return unseen & (self._tracks.unseen + 1 > limit)

    def _emerges(
        self, pred: np.ndarray, dets: Detections, hid: np.ndarray, lik: np.ndarray
    ) -> np.ndarray:
        """(E, 2) ``detection, track`` rows: candidate detections of hidden tracks that touch the
        occluder's predicted box, widened by ``emerge_margin`` of its size on every side."""
        if not (hid.size and len(dets)):
            return np.zeros((0, 2), dtype=np.int64)
        pos = {int(t): i for i, t in enumerate(self._tracks.id.tolist())}
        pairs = [
            (i, pos[o])
            for i, o in zip(hid.tolist(), self._tracks.occluder[hid].tolist(), strict=True)
            if o in pos
        ]
        if not pairs:
            return np.zeros((0, 2), dtype=np.int64)
        tracks, occ = np.array(pairs, dtype=np.int64).T
        x1, y1, x2, y2 = pred[occ].T
        mx, my = (x2 - x1) * self.config.emerge_margin, (y2 - y1) * self.config.emerge_margin
        boxes = np.stack([x1 - mx, y1 - my, x2 + mx, y2 + my], axis=1)
        # (hidden track, detection): a candidate that touches the widened occluder box
        touch = (lik[tracks] > 0) & (intersection(boxes, dets.xyxy) > 0)
        h, d = np.nonzero(touch)
        return _int_columns(d, tracks[h])

    def _abduce(self, pred: np.ndarray, dets: Detections) -> tuple[Answer, bool]:
        """Abduce the frame through the encoding (component by component, see
        :mod:`sensemaking.abduction.components`); Hungarian matching if no model in budget."""
        problem = self._problem(pred, dets)
        answer = self._solver.solve(problem, budget_ms=self.config.max_solve_ms)
        self._frame_problem = problem if answer is not None else None  # for FrameResult.abduction
        if answer is None:
            self.stats["timed_out"] += 1
            self.stats["fallback"] += 1
            return self._hungarian(pred, dets), True
        cut = answer.timed_out or answer.budget_hit
        if cut:
            self.stats["timed_out"] += 1
        return answer, cut

    def _hungarian(self, pred: np.ndarray, dets: Detections) -> Answer:
        """Plain Hungarian IoU matching with the same gates; events only start/end/missing."""
        c = self.config
        lik = self._likelihood(pred, dets)
        ans = Answer()
        matched_t: set[int] = set()
        matched_d: set[int] = set()
        if lik.size:
            rows, cols = linear_sum_assignment(-lik)
            for r, k in zip(rows.tolist(), cols.tolist(), strict=True):
                if lik[r, k] > 0:
                    tid = int(self._tracks.id[r])
                    (ans.assign if self._tracks.unseen[r] == 0 else ans.resume)[tid] = k
                    matched_t.add(r)
                    matched_d.add(k)
        expired = self._expired()
        for r in range(len(self._tracks)):
            if r in matched_t:
                if self._tracks.unseen[r] > 0:
                    ans.events.append(("reappears", (int(self._tracks.id[r]),)))
                continue
            tid = int(self._tracks.id[r])
            if not self._tracks.confirmed[r] or expired[r]:
                ans.end.append(tid)
                ans.events.append(("ends", (tid,)))
            elif self._tracks.unseen[r] == 0:
                ans.halt.append(tid)
                ans.events.append(("missing_detections", (tid,)))
            else:
                ans.ignore_trk.append(tid)
        for k in range(len(dets)):
            if k in matched_d:
                continue
            if dets.confidence[k] >= c.start_confidence:
                ans.start.append(k)
                ans.events.append(("starts", (Det(k),)))
            else:
                ans.ignore_det.append(k)
        return ans

    # -- applying the answer ----------------------------------------------------------------------
    def _apply(
        self, ans: Answer, dets: Detections, frame: int
    ) -> tuple[list[Event], dict[int, int]]:
        """Update the tracks by the answer; return this frame's events and
        ``track id -> detection row`` of every track observed this frame (matched or new)."""
        c = self.config
        if len(self._tracks) == 0 and not (ans.start or ans.events or ans.fluents):
            return [], {}  # no track before or after: nothing to update, confirm or report
        index = self._tracks.row_of()
        # matched tracks
        matched = {**ans.assign, **ans.resume}
        # scene_shift: (centre shift (2,) pixels, velocity change (2,) pixels/frame) or None
        camera: tuple[np.ndarray, np.ndarray] | None = None
        if matched:
            rows = np.array([index[t] for t in matched], dtype=np.int64)
            cols = np.array(list(matched.values()), dtype=np.int64)
            settled = rows[self._settled(rows)] if c.scene_shift else rows[:0]
            if len(settled) >= SCENE_SHIFT_MIN_TRACKS:
                before = self._tracks.kf.motion(settled)
            gaps = self._tracks.unseen[rows]
            back = gaps > 0
            if c.resume_reupdate and back.any():
                if not back.all():
                    self._tracks.kf._update_trusted(rows[~back], dets.xyxy[cols[~back]])
                self._tracks.kf.reupdate(rows[back], dets.xyxy[cols[back]], gaps[back])
            else:
                self._tracks.kf._update_trusted(
                    rows, dets.xyxy[cols]
                )  # distinct rows in range, gated boxes
            if len(settled) >= SCENE_SHIFT_MIN_TRACKS:
                # the median correction of the established tracks' centres and velocities: the
                # image motion of the scene that their predictions missed this frame
                change = np.median(self._tracks.kf.motion(settled) - before, axis=0)
                camera = (change[0], change[1])
            self._tracks.unseen[rows] = 0
            self._tracks.state[rows] = TrackState.VISIBLE
            self._tracks.hits[rows] += 1
            self._tracks.conf[rows] = dets.confidence[cols]
            self._tracks.depth[rows] = dets.depth[cols]
        observed = dict(matched)
        # new tracks (first, so that fluents and events can name them)
        new_vis = {
            a[0].row: v for n, a, v in ans.fluents if n == "visibility" and isinstance(a[0], Det)
        }
        new_ids: dict[Det, int] = {}
        if ans.start:
            cols = np.array(sorted(ans.start), dtype=np.int64)  # new ids in detection order
            ids = np.arange(self._next_id, self._next_id + len(cols), dtype=np.int64)
            self._next_id += len(cols)
            new_ids = {Det(k): int(t) for k, t in zip(cols.tolist(), ids.tolist(), strict=True)}
            vis = [VISIBILITY_VALUES.index(new_vis.get(j, "fully_visible")) for j in cols.tolist()]
            # confirmation of new tracks: by the general rule below
            self._tracks.add(
                ids,
                dets.xyxy[cols],
                dets.class_id[cols],
                dets.confidence[cols],
                np.array(vis),
                velocity=self._scene_velocity(dets.class_id[cols]),
                depth=dets.depth[cols],
            )
            observed.update({new_ids[Det(j)]: j for j in cols.tolist()})
        # fluents: the answer holds the values that changed; the others carry on (inertia)
        for fname, fargs, value in ans.fluents:
            if fname not in ("hidden_by", "visibility"):
                continue  # the tracker carries these two (and in_fov, true while live)
            # None for ended tracks and new ones (a Det, done above)
            i = index.get(fargs[0]) if isinstance(fargs[0], int) else None
            if i is None:
                continue
            if fname == "hidden_by":
                occluder = new_ids[fargs[1]] if isinstance(fargs[1], Det) else fargs[1]
                if value == "true":
                    self._tracks.occluder[i] = occluder
                elif self._tracks.occluder[i] == occluder:
                    self._tracks.occluder[i] = -1
            elif fname == "visibility":
                self._tracks.vis[i] = VISIBILITY_VALUES.index(value)
        # unobserved tracks: hidden behind their occluder, or missing
        for t in ans.halt + ans.ignore_trk:
            i = index[t]
            self._tracks.unseen[i] += 1
            self._tracks.state[i] = (
                TrackState.HIDDEN if self._tracks.occluder[i] >= 0 else TrackState.MISSING
            )
        if camera is not None and (ans.halt or ans.ignore_trk):
            unobserved = np.array([index[t] for t in ans.halt + ans.ignore_trk], dtype=np.int64)
            self._tracks.kf.shift(unobserved, *camera)
        # confirmation (nothing to do when every track is confirmed already)
        events: list[Event] = []
        tentative = ~self._tracks.confirmed
        if tentative.any():
            confirm = (self._tracks.hits >= c.min_hits) | (self._frames_seen <= c.min_hits)
            if c.confirm_confidence is not None:
                confirm |= (self._tracks.unseen == 0) & (self._tracks.conf >= c.confirm_confidence)
            newly_confirmed = tentative & confirm
            self._tracks.confirmed |= newly_confirmed
            # a tentative track's start event waits until the track is confirmed, and is dated
            # then: the first frame the track is output (the event log agrees with the tracks)
            for i in np.flatnonzero(newly_confirmed).tolist():
                pending = self._pending.pop(int(self._tracks.id[i]), None)
                if pending is not None:
                    events.append(replace(pending, frame=frame))
        # events, with detections renamed to their new track ids; a tentative track's events
        # other than its start are not reported
        confirmed = set(self._tracks.id[self._tracks.confirmed].tolist()) if ans.events else set()
        ended = set(ans.end)
        for name, args in ans.events:
            if any(isinstance(a, Det) and a not in new_ids for a in args):
                log.debug("event %s names a detection that starts no track: not reported", name)
                continue
            ids_ = tuple(new_ids[a] if isinstance(a, Det) else a for a in args)
            ev = Event(frame, name, ids_)
            if not ids_ or ids_[0] in confirmed or not isinstance(ids_[0], int):
                events.append(ev)
            elif name in ("enters_fov", "starts"):
                self._pending[ids_[0]] = ev
        # drop ended tracks
        if ended:
            self._tracks.drop(
                np.array([t not in ended for t in self._tracks.id.tolist()], dtype=bool)
            )
            for t in ended:
                self._pending.pop(t, None)
        events.sort(key=Event.sort_key)
        return events, observed

    def _settled(self, rows: np.ndarray | slice = slice(None)) -> np.ndarray:
        """(K,) bool of ``rows`` (default every track): established tracks, visible last frame
        and seen ``min_hits`` + 2 times or more (their velocity is known)."""
        t = self._tracks
        return (t.unseen[rows] == 0) & (t.hits[rows] >= self.config.min_hits + 2)

    def _scene_velocity(self, classes: np.ndarray | None = None) -> np.ndarray:
        """(K, 4) prior velocity of K new tracks of ``classes`` (pixels per frame): the median
        ``cx, cy`` velocity of the established visible tracks of the same class, 0 without
        ``inherit_motion`` or without any of them ((4,) over every class when ``classes`` is
        None). One established track is enough: a lone car leading a convoy into view is the
        only motion known, and the fit at rest still counts for the new tracks (see
        ``_uncertain``). Per class because cars and pedestrians move apart: a joint run of
        several classes starts each class's tracks as its own run would."""
        pooled = classes is None
        kinds = np.zeros(1, dtype=np.int64) if classes is None else np.asarray(classes)
        prior = np.zeros((len(kinds), 4))
        if self.config.inherit_motion and len(self._tracks):
            settled = self._settled()
            velocity = self._tracks.kf.velocity()[:, :2]
            for cls in np.unique(kinds).tolist():
                same = settled if pooled else settled & (self._tracks.cls == cls)
                if same.any():
                    prior[kinds == cls, :2] = np.median(velocity[same], axis=0)
        return prior[0] if pooled else prior

    def _output(self, dets: Detections, observed: dict[int, int], frame: int) -> Detections:
        """Every live confirmed track: its detection's box if observed, else the prediction."""
        n = len(self._tracks)
        if n == 0:
            return _no_tracks()  # most frames of sparse sequences
        boxes = self._tracks.kf.xyxy()
        rows = np.full(n, -1, dtype=np.int64)
        if observed:
            pos = {int(t): i for i, t in enumerate(self._tracks.id.tolist())}
            idx = np.array([pos[t] for t in observed], dtype=np.int64)
            cols = np.array(list(observed.values()), dtype=np.int64)
            boxes[idx] = dets.xyxy[cols]
            rows[idx] = dets.source_row[cols]
        keep = self._tracks.confirmed
        # boolean indexing copies: the columns never alias the tracker's state
        return _track_output(
            boxes[keep],
            self._tracks.conf[keep],
            self._tracks.cls[keep],
            self._tracks.id[keep],
            np.full(int(keep.sum()), frame, dtype=np.int64),
            rows[keep],
            self._tracks.state[keep],
            self._tracks.occluder[keep],
            self._tracks.vis[keep],
            self._tracks.unseen[keep],
        )


def _track_output(
    xyxy: np.ndarray,
    confidence: np.ndarray,
    class_id: np.ndarray,
    tracker_id: np.ndarray,
    frame: np.ndarray,
    source_row: np.ndarray,
    state: np.ndarray,
    occluder: np.ndarray,
    visibility: np.ndarray,
    hidden_frames: np.ndarray,
) -> Detections:
    """The columns of :meth:`Tracker._output` (N rows; ``xyxy`` (N, 4) float pixels, the rest
    (N,)), which have the validated dtypes and shapes already: no validation every frame."""
    return Detections.trusted(
        xyxy=xyxy,
        confidence=confidence,
        class_id=class_id,
        tracker_id=tracker_id,
        frame=frame,
        source_row=source_row,
        data={
            "state": state,
            "occluder": occluder,
            "visibility": visibility,
            "hidden_frames": hidden_frames,
        },
    )


def _no_tracks() -> Detections:
    """:meth:`Tracker._output` without tracks: empty columns of its dtypes (fresh arrays)."""

    def ints() -> np.ndarray:
        return np.empty(0, dtype=np.int64)

    return _track_output(
        np.empty((0, 4)),
        np.empty(0),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
    )


def _quantize(x: np.ndarray, levels: int, rounding=np.rint) -> np.ndarray:
    """Values in [0, 1] -> integers 0..1000 on a grid of ``levels`` steps (``np.rint``: what
    ``np.round`` calls for 0 decimals, without its Python layers)."""
    return (rounding(np.minimum(np.maximum(x, 0.0), 1.0) * levels + 1e-9) * 1000 // levels).astype(
        np.int64
    )


@lru_cache(maxsize=16)
def _floored_grid(levels: int, iou: tuple[float, ...]) -> tuple[int, ...]:
    """IoU thresholds on the solver's grid of ``levels`` steps, rounded down (asked every
    frame)."""
    return tuple(_quantize(np.array(iou), levels, np.floor).tolist())


@lru_cache(maxsize=16)
def _image_limits(
    image_size: tuple[int, int], margin: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """``margin``, the image as a (1, 4) box and ``(w - margin, h - margin)`` (asked every frame;
    shared arrays: not to be modified)."""
    w, h = image_size
    return (
        margin,
        np.array([[0.0, 0.0, w, h]]),
        np.array([w - margin, h - margin], dtype=np.float64),
    )


def _int_columns(*cols: np.ndarray) -> np.ndarray:
    """``np.stack(cols, axis=1).astype(np.int64)`` for 1-d integer arrays of one length (an
    empty array and one assignment per column: fewer Python layers than np.stack)."""
    out = np.empty((len(cols[0]), len(cols)), dtype=np.int64)
    for i, col in enumerate(cols):
        out[:, i] = col
    return out


def _widen(boxes: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """(N, 4) ``xyxy`` boxes scaled about their centres by (N,) ``factor``."""
    c = (boxes[:, :2] + boxes[:, 2:]) / 2
    half = (boxes[:, 2:] - boxes[:, :2]) / 2 * factor[:, None]
    return np.concatenate([c - half, c + half], axis=1)


def _coerce(obj: Any) -> Detections:
    if isinstance(obj, Detections):
        return obj
    from sensemaking.adapters import (
        as_detections,
    )  # duck-typed adapters (supervision, ultralytics, arrays)

    return as_detections(obj)

"""Hand-built frame-result sequences for the reasoning tests (a geometric oracle plays the
tracker).

Objects move along scripted boxes; per frame the oracle decides what a perfect tracker would
report: an object whose box is covered at least ``hide_cover`` by a single nearer object (larger
box bottom) is HIDDEN behind it, with a constant-velocity prediction as its box; ``missing``
frames make it MISSING; events follow the state changes (enters_fov at the border, starts
elsewhere, hides_behind, unhides_from_behind, missing_detections, reappears, leaves_fov, ends).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.results import Event, FrameResult, TrackState, Visibility
from sensemaking.scene import Scene, SceneRecorder

W, H = 1242, 375
CAR, VAN, TRUCK = CLASS_IDS["car"], CLASS_IDS["van"], CLASS_IDS["truck"]
PED, CYC = CLASS_IDS["pedestrian"], CLASS_IDS["cyclist"]


@dataclass
class Obj:
    """A scripted object: ``boxes[frame] = (x1, y1, x2, y2)``; ``missing`` frames go undetected."""

    id: int
    cls: int
    boxes: Mapping[int, Sequence[float]]
    missing: set[int] = field(default_factory=set)


def linear(
    frames: Iterable[int],
    box: Sequence[float],
    vel: Sequence[float] = (0, 0, 0, 0),
    start: int | None = None,
) -> dict[int, np.ndarray]:
    """Boxes ``box + vel * (f - start)`` (pixels, px/frame per corner) for each frame."""
    frames = list(frames)
    s = frames[0] if start is None else start
    b, v = np.asarray(box, float), np.asarray(vel, float)
    return {f: b + v * (f - s) for f in frames}


def piecewise(keys: Sequence[tuple[int, Sequence[float]]]) -> dict[int, np.ndarray]:
    """Boxes interpolated linearly between keyframes ``(frame, box)``."""
    out = {}
    for (f0, b0), (f1, b1) in zip(keys, keys[1:], strict=False):
        b0, b1 = np.asarray(b0, float), np.asarray(b1, float)
        for f in range(f0, f1 + 1):
            out[f] = b0 + (b1 - b0) * (f - f0) / (f1 - f0)
    return out


def _coverage(a: np.ndarray, b: np.ndarray) -> float:
    w = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    return w * h / max((a[2] - a[0]) * (a[3] - a[1]), 1e-9)


def _at_border(b: np.ndarray, size: tuple[int, int], margin: float = 10.0) -> bool:
    return b[0] <= margin or b[1] <= margin or b[2] >= size[0] - margin or b[3] >= size[1] - margin


def build_results(
    objs: Sequence[Obj],
    n_frames: int | None = None,
    *,
    size: tuple[int, int] = (W, H),
    hide_cover: float = 0.5,
    partial_cover: float = 0.1,
    noise_px: float = 0.0,
    seed: int = 0,
    first_frame: int = 0,
) -> list[FrameResult]:
    """The frame results a perfect tracker would give for the scripted objects."""
    rng = np.random.default_rng(seed)
    last = max(max(o.boxes) for o in objs) if objs else 0
    n = (last + 1 - first_frame) if n_frames is None else n_frames
    prev_state: dict[int, TrackState] = {}
    prev_occ: dict[int, int] = {}
    seen: dict[int, list[tuple[int, np.ndarray]]] = {}  # visible history
    unseen: dict[int, int] = {}
    out = []
    for f in range(first_frame, first_frame + n):
        present = [o for o in objs if f in o.boxes]
        events: list[Event] = []
        rows = []
        for o in present:
            b = np.asarray(o.boxes[f], float)
            best, occ = 0.0, -1
            for p in present:
                if p is o:
                    continue
                pb = np.asarray(p.boxes[f], float)
                if pb[3] > b[3]:
                    c = _coverage(b, pb)
                    if c > best:
                        best, occ = c, p.id
            if best >= hide_cover:
                state = TrackState.HIDDEN
            elif f in o.missing:
                state, occ = TrackState.MISSING, -1
            else:
                state, occ = TrackState.VISIBLE, -1
            vis = (
                Visibility.FULLY_OCCLUDED
                if state == TrackState.HIDDEN
                else Visibility.PARTIALLY_OCCLUDED
                if best >= partial_cover
                else Visibility.FULLY_VISIBLE
            )
            if state == TrackState.VISIBLE:
                box = b + (rng.normal(0, noise_px, 4) if noise_px else 0.0)
                seen.setdefault(o.id, []).append((f, box))
                unseen[o.id] = 0
            else:
                hist = seen.get(o.id, [])
                if len(hist) >= 2:
                    (f0, b0), (f1, b1) = hist[-2], hist[-1]
                    box = b1 + (b1 - b0) / (f1 - f0) * (f - f1)
                elif hist:
                    box = hist[-1][1]
                else:
                    box = b
                unseen[o.id] = unseen.get(o.id, 0) + 1
            before = prev_state.get(o.id)
            if before is None:
                events.append(
                    Event(
                        f,
                        "enters_fov" if _at_border(b, size) and f > first_frame else "starts",
                        (o.id,),
                    )
                )
            elif before == TrackState.VISIBLE and state == TrackState.HIDDEN:
                events.append(Event(f, "hides_behind", (o.id, occ)))
            elif before == TrackState.VISIBLE and state == TrackState.MISSING:
                events.append(Event(f, "missing_detections", (o.id,)))
            elif before == TrackState.HIDDEN and state == TrackState.VISIBLE:
                events.append(Event(f, "unhides_from_behind", (o.id, prev_occ[o.id])))
            elif before == TrackState.MISSING and state == TrackState.VISIBLE:
                events.append(Event(f, "reappears", (o.id,)))
            prev_state[o.id], prev_occ[o.id] = state, occ
            rows.append((o.id, o.cls, box, state, occ, vis, unseen[o.id]))
        gone = [t for t in prev_state if t not in {o.id for o in present}]
        for t in gone:
            o = next(o for o in objs if o.id == t)
            lastb = np.asarray(o.boxes[max(k for k in o.boxes if k < f)], float)
            events.append(Event(f, "leaves_fov" if _at_border(lastb, size) else "ends", (t,)))
            del prev_state[t]
        tracks = Detections(
            xyxy=np.array([r[2] for r in rows]).reshape(-1, 4),
            class_id=[r[1] for r in rows],
            tracker_id=[r[0] for r in rows],
            frame=np.full(len(rows), f),
            data={
                "state": np.array([int(r[3]) for r in rows], dtype=np.int64),
                "occluder": np.array([r[4] for r in rows], dtype=np.int64),
                "visibility": np.array([int(r[5]) for r in rows], dtype=np.int64),
                "hidden_frames": np.array([r[6] for r in rows], dtype=np.int64),
            },
        )
        out.append(FrameResult(f, tracks, sorted(events)))
    return out


def build_scene(
    objs: Sequence[Obj],
    n_frames: int | None = None,
    *,
    fps: float = 10.0,
    size: tuple[int, int] = (W, H),
    **kw,
) -> Scene:
    """The :class:`Scene` a recorder makes of :func:`build_results`."""
    rec = SceneRecorder(fps=fps, image_size=size)
    for r in build_results(objs, n_frames, size=size, **kw):
        rec.add(r)
    return rec.scene()


# -- a few standard scenes ------------------------------------------------------------------------
def cyclist_behind_turning_car(n: int = 45) -> list[Obj]:
    """A cyclist (id 1) crossing to the right passes behind a car (id 2) turning left across
    the road ahead; the cyclist reappears in front of the ego vehicle."""
    cyc = Obj(1, CYC, linear(range(n), (430, 180, 478, 254), (6, 0, 6, 0)))
    car = Obj(2, CAR, linear(range(n), (760, 170, 960, 290), (-9, 0, -9, 0)))
    return [cyc, car]


def hidden_interval(results: Sequence[FrameResult], track: int) -> tuple[int, int]:
    """First and last frame at which ``track`` is HIDDEN."""
    fs = [r.frame for r in results if r.state_of(track) == TrackState.HIDDEN]
    return fs[0], fs[-1]


# -- tests of the oracle itself -------------------------------------------------------------------
def test_oracle_hides_and_unhides_the_cyclist():
    results = build_results(cyclist_behind_turning_car())
    a, b = hidden_interval(results, 1)
    assert 0 < a < b < 44
    names = [(e.name, e.args) for r in results for e in r.events]
    assert ("hides_behind", (1, 2)) in names and ("unhides_from_behind", (1, 2)) in names
    assert all(r.state_of(2) == TrackState.VISIBLE for r in results)


def test_oracle_missing_frames_and_end_events():
    o = Obj(5, CAR, linear(range(3, 12), (500, 200, 600, 260)), missing={6, 7})
    results = build_results([o], 14)
    names = [(e.frame, e.name) for r in results for e in r.events]
    assert names == [(3, "starts"), (6, "missing_detections"), (8, "reappears"), (12, "ends")]
    assert results[6].tracks.data["hidden_frames"].tolist() == [1]

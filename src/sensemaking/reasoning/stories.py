"""The scene's story in sentences: each track from its start to its end (``explain``)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from sensemaking.results import Event, TrackState, Visibility
from sensemaking.vocabulary import START_EVENTS

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.reasoning.context import SceneContext
    from sensemaking.scene import Scene, Track

__all__ = ["explain", "stories"]


# -- formatting helpers ---------------------------------------------------------------------------
def duration(scene: Scene, frames: int) -> str:
    return f"{frames} frame{'s' if frames != 1 else ''} ({scene.seconds(frames):.1f} s)"


def missing_track(scene: Scene, track_id: int) -> str:
    ids = list(scene.tracks)
    listing = ", ".join(map(str, ids[:20])) + (", ..." if len(ids) > 20 else "")
    return f"track {track_id} does not appear in this scene" + (
        f" (tracks: {listing})" if ids else " (it has no tracks)"
    )


def where_phrase(scene: Scene, box: Any, context: SceneContext | None = None) -> str:
    """Coarse place of a box in the image: left / right / in front of the ego vehicle."""
    if scene.image_size is None:
        return f"at x={(box[0] + box[2]) / 2:.0f}, y={box[3]:.0f} px"
    from sensemaking.reasoning.context import Corridor

    corr = context.corridor if context is not None else Corridor()
    w = scene.image_size[0]
    cx = (box[0] + box[2]) / 2
    if corr.contains_boxes(np.asarray(box, dtype=np.float64), scene.image_size)[0]:
        place = "in front of the ego vehicle"
    else:
        place = "on the left" if cx < w / 3 else "on the right" if cx > 2 * w / 3 else "ahead"
    return f"{place} (x={cx:.0f}, y={box[3]:.0f} px)"


def border_phrase(scene: Scene, box: Any, margin: float = 15.0) -> str:
    if scene.image_size is None:
        return ""
    w, h = scene.image_size
    sides = [
        ("left", box[0] <= margin),
        ("right", box[2] >= w - margin),
        ("top", box[1] <= margin),
        ("bottom", box[3] >= h - margin),
    ]
    hit = [s for s, ok in sides if ok]
    return f" at the {' and '.join(hit)} border" if hit else ""


# -- stories --------------------------------------------------------------------------------------
def _motion_summary(scene: Scene, t: Track) -> str | None:
    from sensemaking.reasoning.egomotion import world_story

    world = world_story(scene, t.id)  # over the road, when recorded with a camera model
    if world is not None:
        return world
    vis = t.visible_mask()
    if vis.sum() < 2:
        return None
    f = t.frames[vis]
    b = t.xyxy[vis]
    dt = scene.seconds(int(f[-1] - f[0]))
    if dt <= 0:
        return None
    vx = ((b[-1, 0] + b[-1, 2]) - (b[0, 0] + b[0, 2])) / 2 / dt
    h0, h1 = b[0, 3] - b[0, 1], b[-1, 3] - b[-1, 1]
    ratio = h1 / h0 if h0 > 0 else 1.0
    parts = []
    if abs(vx) >= 20.0:
        parts.append(f"moves {'right' if vx > 0 else 'left'} at about {abs(vx):.0f} px/s")
    if ratio >= 1.15 and b[-1, 3] > b[0, 3]:
        parts.append("comes closer")
    elif ratio <= 1 / 1.15 and b[-1, 3] < b[0, 3]:
        parts.append("moves away")
    if not parts:
        return "It stays roughly in place in the image."
    return "It " + " and ".join(parts) + "."


def _story(scene: Scene, t: Track, context: SceneContext | None) -> list[str]:
    d = scene.describe(t.id)
    evs = scene.events_of(t.id)
    own = [e for e in evs if e.args and e.args[0] == t.id]
    first = f"{d[0].upper()}{d[1:]}"
    where = where_phrase(scene, t.xyxy[0], context)
    start = next((e for e in own if e.name in START_EVENTS), None)
    if start is not None and start.name == "enters_fov":
        out = [
            f"{first} enters the field of view at frame {start.frame}"
            f"{border_phrase(scene, t.xyxy[0])}, {where}."
        ]
    elif t.first == scene.first_frame:
        out = [f"{first} is in view from the first frame ({t.first}), {where}."]
    else:
        out = [f"{first} appears at frame {t.first}, {where}."]
    m = _motion_summary(scene, t)
    if m:
        out.append(m)
    hidden = {(f.args[1], f.start): f for f in scene.fluent_intervals("hidden_by", t.id)}
    gap_from: int | None = None
    # a track revived (revive_s) left or was lost first: each end but the last is told with
    # its return; the last is the end of the story
    revived = [e.frame for e in own if e.name in ("reenters_fov", "returns")]
    last_back = max(revived, default=None)
    ended: Event | None = None
    for e in evs:
        if e.name == "hides_behind" and e.args[0] == t.id:
            out.append(f"At frame {e.frame} it hides behind {scene.describe(int(e.args[1]))}.")
        elif e.name == "hides_behind" and len(e.args) > 1 and e.args[1] == t.id:
            out.append(f"At frame {e.frame} it hides {scene.describe(int(e.args[0]))} from view.")
        elif e.name == "may_hide_behind" and e.args[0] == t.id:
            out.append(
                f"At frame {e.frame} it may be hiding behind {scene.describe(int(e.args[1]))}."
            )
        elif e.name == "unhides_from_behind" and e.args[0] == t.id:
            ep = max(
                (iv for (o, s), iv in hidden.items() if o == e.args[1] and s < e.frame),
                key=lambda iv: iv.start,
                default=None,
            )
            took = f" after {duration(scene, e.frame - ep.start)}" if ep else ""
            out.append(
                f"At frame {e.frame} it comes out from behind "
                f"{scene.describe(int(e.args[1]))}{took}."
            )
        elif e.name == "unhides_from_behind" and len(e.args) > 1 and e.args[1] == t.id:
            out.append(
                f"At frame {e.frame} {scene.describe(int(e.args[0]))} comes out from behind it."
            )
        elif e.name == "missing_detections" and e.args[0] == t.id:
            gap_from = e.frame
            out.append(f"From frame {e.frame} its detections are missing.")
        elif e.name == "reappears" and e.args[0] == t.id:
            took = (
                f" after {duration(scene, e.frame - gap_from)}"
                if gap_from is not None and gap_from < e.frame
                else ""
            )
            out.append(f"At frame {e.frame} it is detected again{took}.")
            gap_from = None
        elif e.name in ("leaves_fov", "ends") and e.args[0] == t.id:
            if last_back is not None and e.frame < last_back:
                ended = e
        elif e.name in ("reenters_fov", "returns") and e.args[0] == t.id:
            out.append(_return_sentence(scene, t, e, ended))
            ended = None
    k = len(t) - 1
    after = -1 if last_back is None else last_back
    leave = next((e for e in own if e.name == "leaves_fov" and e.frame > after), None)
    end = next((e for e in own if e.name == "ends" and e.frame > after), None)
    if leave is not None:
        out.append(
            f"At frame {leave.frame} it leaves the field of view{border_phrase(scene, t.xyxy[k])}."
        )
    elif end is not None:
        unseen = int(t.hidden_frames[k])
        why = f" unseen for {duration(scene, unseen)}," if unseen else ""
        out.append(
            f"At frame {end.frame} the track ends:{why} its absence could no longer be explained."
        )
    elif t.last == scene.last_frame:
        st = TrackState(int(t.state[k]))
        now = {
            TrackState.VISIBLE: "visible",
            TrackState.MISSING: "with missing detections",
            TrackState.HIDDEN: f"hidden behind {scene.describe(int(t.occluder[k]))}",
        }[st]
        vis = Visibility(int(t.visibility[k]))
        if st == TrackState.VISIBLE and vis == Visibility.PARTIALLY_OCCLUDED:
            now += ", partially occluded"
        out.append(f"It is still tracked at the end of the scene (frame {t.last}), {now}.")
    else:
        out.append(f"It was last tracked at frame {t.last}.")
    return out


def _return_sentence(scene: Scene, t: Track, e: Event, ended: Event | None) -> str:
    """A revived track's return (``reenters_fov`` / ``returns``), with how it had ended."""
    k = int(np.searchsorted(t.frames, e.frame))
    box = t.xyxy[min(k, len(t) - 1)]
    if e.name == "reenters_fov":
        left = f" (it left at frame {ended.frame})" if ended is not None else ""
        at = border_phrase(scene, box)
        return f"At frame {e.frame} it re-enters the field of view{at}{left}."
    lost = f" (lost at frame {ended.frame})" if ended is not None else ""
    return f"At frame {e.frame} it is found again{lost}."


def stories(scene: Scene, *, context: SceneContext | None = None) -> dict[int, list[str]]:
    """Each track's story (track id -> sentences), tracks in order of appearance."""
    order = sorted(scene.tracks.values(), key=lambda t: (t.first, t.id))
    return {t.id: _story(scene, t, context) for t in order}


def explain(
    scene: Scene, track_id: int | None = None, *, context: SceneContext | None = None
) -> list[str]:
    """The story of one track (or of every track, in order of appearance) as sentences.

    A track that is not in the scene gets the one sentence saying so.
    """
    if track_id is not None:
        if track_id not in scene:
            return [missing_track(scene, track_id)]
        return _story(scene, scene.tracks[int(track_id)], context)
    out: list[str] = []
    for sentences in stories(scene, context=context).values():
        out.extend(sentences)
    return out or ["this scene has no tracks"]

"""A self-contained HTML report of a run: timeline, stories, warnings, metrics and key frames.

One file that opens offline: CSS, JavaScript and SVG are inline and the frame thumbnails are
``data:`` URIs (PNG on a plain canvas, JPEG over pictures); the file contains no external URL.

Sections:

* **Timeline** — one SVG row per track (``<g class="track-row" data-track="ID">``): coloured spans
  for visible / hidden / missing, event markers with tooltips, a row of warning markers.
* **Warnings** — every warning (``<ol class="warnings">``), linked to its key frame.
* **Stories** — each track's story (``<article class="story" id="track-ID">``): the sentences of
  :func:`sensemaking.reasoning.explain` when it is available, else a story built from the
  track's states and events.
* **Metrics** — with ground truth: the :mod:`sensemaking.evaluation` table per scored class.
* **Explanations** — with ground truth and hidings in the run: the precision-recall curve
  (inline SVG) and table of each hiding kind against its confidence (:func:`explanation_curves`).
* **Key frames** — thumbnails of the frames where events or warnings happen, with the
  explanation drawn (:class:`~sensemaking.viz.render.FrameDrawer`).
"""

from __future__ import annotations

import base64
import html
import io
import logging
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.io.atomic import atomic_write
from sensemaking.results import TrackState
from sensemaking.viz import _style as st
from sensemaking.viz._run import Run, Span, as_run, scene_of
from sensemaking.viz._style import _get

__all__ = [
    "build_report",
    "write_report",
    "key_frames",
    "track_story",
    "explanation_curves",
    "METRIC_COLUMNS",
]

log = logging.getLogger(__name__)

#: metric columns of the report's table (TrackEval field names)
METRIC_COLUMNS = (
    "HOTA",
    "DetA",
    "AssA",
    "MOTA",
    "MOTP",
    "IDF1",
    "IDSW",
    "Frag",
    "CLR_FP",
    "CLR_FN",
    "MT",
    "PT",
    "ML",
    "GT_IDs",
    "IDs",
)

#: event name -> (marker colour, importance for choosing key frames)
_EVENT_STYLE: dict[str, tuple[str, int]] = {
    "hides_behind": ("#e8871e", 3),
    "may_hide_behind": ("#f0b27a", 2),
    "unhides_from_behind": ("#c2571a", 3),
    "missing_detections": ("#6b7280", 2),
    "reappears": ("#2563eb", 2),
    "enters_fov": ("#16a34a", 2),
    "leaves_fov": ("#7c3aed", 2),
    "starts": ("#94a3b8", 1),
    "ends": ("#475569", 1),
}


# stories ---------------------------------------------------------------------------------------
def _explain_function() -> Any:
    try:
        from sensemaking.reasoning.questions import explain

        return explain
    except ImportError:
        return None


def _sentences(value: Any) -> list[str]:
    if value is None:
        return []
    if isinstance(value, str):
        return [value] if value.strip() else []
    if isinstance(value, Iterable):
        return [str(getattr(v, "text", v)) for v in value if str(getattr(v, "text", v)).strip()]
    return [str(value)]


def _frames_text(a: int, b: int) -> str:
    return f"frame {a}" if a == b else f"frames {a}–{b}"


def fallback_story(run: Run, track_id: int) -> list[str]:
    """A track's story from its states and events alone (used when reasoning is not available):
    when it was tracked, then each event involving it, with how long a hiding or a gap lasted."""
    classes = run.classes
    spans = run.spans.get(track_id, [])
    if not spans:
        return []

    def lasting(sp: Span) -> str:
        n = sp.end - sp.start + 1
        text = f"{n} frame{'s' if n != 1 else ''}"
        return text + (f", {n / run.fps:.1f} s" if run.fps else "")

    pending = {sp.start: sp for sp in spans if sp.state != TrackState.VISIBLE}
    items: list[tuple[int, str]] = []
    for e in run.events:
        if track_id not in e.args:
            continue
        text = f"Frame {e.frame}: {st.event_sentence(e.name, e.args, classes)}"
        if e.confidence is not None:
            text += f" (confidence {e.confidence:.2f})"
        if e.args[0] == track_id and e.name in (
            "hides_behind",
            "may_hide_behind",
            "missing_detections",
        ):
            sp = pending.pop(e.frame, None) or pending.pop(e.frame + 1, None)
            if sp is not None:
                text += f" (for {lasting(sp)})"
        items.append((e.frame, text + "."))
    for sp in pending.values():  # states no event explains
        if sp.state == TrackState.HIDDEN:
            who = (
                st.track_label(sp.occluder, classes.get(sp.occluder))
                if sp.occluder >= 0
                else "another object"
            )
            what = f"hidden behind {who}"
        else:
            what = "not detected"
        items.append(
            (sp.start, f"{_frames_text(sp.start, sp.end).capitalize()}: {what} ({lasting(sp)}).")
        )
    items.sort(key=lambda t: t[0])
    label = st.track_label(track_id, classes.get(track_id))
    first, last = spans[0].start, spans[-1].end
    n_vis = sum(sp.end - sp.start + 1 for sp in spans if sp.state == TrackState.VISIBLE)
    intro = (
        f"{label} was tracked from frame {first} to frame {last}"
        + (f" ({(last - first + 1) / run.fps:.1f} s)" if run.fps else "")
        + f", visible in {n_vis} of {last - first + 1} frames."
    )
    return [intro] + [t[1] for t in items]


def track_story(run: Run, track_id: int, explain: Any = None) -> tuple[list[str], str]:
    """(sentences, source) of a track's story; source is ``"reasoning"`` or ``"events"``."""
    explain = _explain_function() if explain is None else explain
    if explain is not None:
        scene = scene_of(run)
        if scene is not None:
            try:
                sentences = _sentences(explain(scene, track_id))
            except (KeyError, ValueError, LookupError) as exc:
                log.debug("explain(%s) failed: %s; using the event story", track_id, exc)
            else:
                if sentences:
                    return sentences, "reasoning"
    return fallback_story(run, track_id), "events"


# key frames ------------------------------------------------------------------------------------
def key_frames(run: Run, limit: int = 24) -> list[int]:
    """Frames worth a thumbnail: where warnings and events happen, most important first, spread
    out (no two closer than ``len / (2 * limit)`` frames), returned in frame order."""
    # a frame's score: its most important happening first, then how many things happen
    best: dict[int, int] = {}
    count: dict[int, int] = {}
    for e in run.events:
        best[e.frame] = max(best.get(e.frame, 0), _EVENT_STYLE.get(e.name, ("", 1))[1])
        count[e.frame] = count.get(e.frame, 0) + 1
    for w in run.warnings:
        if st.is_note(w):
            continue
        f = int(_get(w, "frame", -1))
        best[f] = 5
        count[f] = count.get(f, 0) + 1
    score = {f: 100 * b + count[f] for f, b in best.items()}
    if not score:
        frames = list(run.frames)
        if not frames:
            return []
        n = min(limit, 6, len(frames))
        return sorted(
            {frames[int(round(i * (len(frames) - 1) / max(n - 1, 1)))] for i in range(n)}
        )
    gap = max(len(run.frames) // (2 * max(limit, 1)), 1)
    chosen: list[int] = []
    for f in sorted(score, key=lambda f: (-score[f], f)):
        if len(chosen) >= limit:
            break
        if all(abs(f - c) >= gap for c in chosen):
            chosen.append(f)
    return sorted(chosen)


# metrics ---------------------------------------------------------------------------------------
def _guess_format(path: Path) -> str:
    from sensemaking.io.tables import first_line

    found = first_line(path)
    if found is None:
        raise InputError("empty ground-truth file", path)
    return "mot" if "," in found[1] else "kitti"


def _run_tracks(run: Run) -> Detections:
    parts = [r.visible for r in run.results if len(r.tracks)]
    if not parts:
        return Detections.empty()
    return Detections.concatenate(
        [
            Detections(
                xyxy=p.xyxy,
                confidence=p.confidence,
                class_id=p.class_id,
                tracker_id=p.tracker_id,
                frame=p.frame,
            )
            for p in parts
        ]
    )


def _ground_truth(
    gt: str | os.PathLike[str] | Detections, gt_format: str | None
) -> tuple[Detections, str | None, Path | None]:
    """Ground truth as Detections, its format (guessed from a file when None) and its path
    (None for Detections given)."""
    if isinstance(gt, Detections):
        return gt, gt_format, None
    path = Path(gt)
    if not path.is_file():
        raise InputError("no such ground-truth file", path)
    gt_format = gt_format or _guess_format(path)
    if gt_format == "mot":
        from sensemaking.io.mot import read_mot

        return read_mot(path, "gt"), gt_format, path
    if gt_format == "kitti":
        from sensemaking.io.kitti import read_kitti_labels

        return read_kitti_labels(path), gt_format, path
    raise InputError(f"unknown ground-truth format {gt_format!r} (mot or kitti)", path)


def compute_metrics(
    run: Run,
    gt: str | os.PathLike[str] | Detections,
    gt_format: str | None = None,
    idsw_mode: str = "trackeval",
) -> list[tuple[str, Any]]:
    """(label, SequenceMetrics) per scored class of the run's visible boxes against ground truth.

    ``gt``: a MOTChallenge ``gt.txt`` or KITTI ``label_02`` file (``gt_format`` ``"mot"`` /
    ``"kitti"``, guessed from the file when None) or Detections (then ``gt_format`` is needed).
    MOT: rules ``mot17`` (``mot15`` when the file has no class column). KITTI: ``kitti-car`` and
    ``kitti-pedestrian`` for the classes the run tracked.
    """
    from sensemaking.evaluation import evaluate_sequence

    gt, gt_format, path = _ground_truth(gt, gt_format)
    if gt_format not in ("mot", "kitti"):
        raise ValueError("gt_format must be 'mot' or 'kitti' for ground truth given as Detections")
    tracks = _run_tracks(run)
    assert tracks.class_id is not None  # Detections fills every column
    out: list[tuple[str, Any]] = []
    if gt_format == "mot":
        if len(tracks) and not np.any(np.isin(tracks.class_id, (0, CLASS_IDS["pedestrian"]))):
            raise InputError(
                "MOTChallenge ground truth scores pedestrians; the run has no pedestrian tracks",
                path,
            )
        vis = gt.data.get("visibility")
        rules = (
            "mot15" if vis is not None and len(vis) and np.all(np.asarray(vis) == -1) else "mot17"
        )
        people = (
            tracks[np.isin(tracks.class_id, (0, CLASS_IDS["pedestrian"]))]
            if len(tracks)
            else tracks
        )
        people = people.with_(class_id=np.full(len(people), CLASS_IDS["pedestrian"]))
        out.append(
            (
                f"{rules} pedestrian",
                evaluate_sequence(
                    gt, people, rules, idsw_mode=idsw_mode, name=run.name, gt_path=path
                ),
            )
        )
        return out
    for cls in ("car", "pedestrian"):
        if len(tracks) and np.any(tracks.class_id == CLASS_IDS[cls]):
            out.append(
                (
                    f"kitti {cls}",
                    evaluate_sequence(
                        gt,
                        tracks,
                        f"kitti-{cls}",
                        idsw_mode=idsw_mode,
                        name=run.name,
                        gt_path=path,
                    ),
                )
            )
    if not out:
        raise InputError(
            "the run has no car or pedestrian tracks to score against KITTI ground truth", path
        )
    return out


def explanation_curves(
    run: Run,
    gt: str | os.PathLike[str] | Detections,
    gt_format: str | None = None,
) -> str:
    """HTML of the run's events judged against ground truth: per event kind with a confidence
    (the hidings), the precision-recall curve (inline SVG) and its table
    (:mod:`sensemaking.evaluation.curves`); empty when the run has no such event."""
    from sensemaking.evaluation.curves import confidence_rows_html, pr_curve_svg
    from sensemaking.evaluation.explanations import GroundTruth, evaluate_explanations

    if not any(e.name in ("hides_behind", "may_hide_behind") for e in run.events):
        return ""
    gt, gt_format, _ = _ground_truth(gt, gt_format)
    tracks = _run_tracks(run)
    if gt_format == "mot":
        truth = GroundTruth.from_mot(gt, image_size=run.size(), fps=float(run.fps or 30.0))
    else:
        names = [c for c in ("car", "pedestrian") if np.any(tracks.class_id == CLASS_IDS[c])]
        truth = GroundTruth.from_kitti(
            gt, image_size=run.size(), fps=float(run.fps or 10.0), classes=names or ("car",)
        )
    result = evaluate_explanations(truth, tracks, run.events, name=run.name or "")
    events = result.summary()["events"]
    blocks = []
    for kind in ("hides_behind", "may_hide_behind"):
        row = events.get(kind, {})
        rows = row.get("by_confidence")
        if rows and row.get("total"):
            blocks.append(
                f'<figure class="pr" data-kind="{kind}">{pr_curve_svg(rows, kind)}'
                f"<figcaption>{confidence_rows_html(rows)}</figcaption></figure>"
            )
    return "".join(blocks)


# HTML pieces -----------------------------------------------------------------------------------
_CSS = """
:root{--fg:#1f2430;--dim:#5b6270;--line:#e3e6ec;--bg:#fafbfc;--card:#fff;--warn:#d92d2d}
*{box-sizing:border-box}
body{margin:0;font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;
  color:var(--fg);background:var(--bg)}
main{max-width:1180px;margin:0 auto;padding:18px 22px 60px}
h1{font-size:22px;margin:4px 0 2px}
h2{font-size:17px;margin:28px 0 8px;border-bottom:1px solid var(--line);padding-bottom:4px}
h3{font-size:14px;margin:0 0 4px}
.summary{color:var(--dim);margin:0 0 8px}
nav a{margin-right:14px;color:#2457c5;text-decoration:none}
.legend{display:flex;flex-wrap:wrap;gap:14px;color:var(--dim);font-size:12px;margin:4px 0 8px}
.legend i{display:inline-block;width:18px;height:9px;border-radius:2px;margin-right:5px;
  vertical-align:middle}
.legend b{display:inline-block;width:9px;height:9px;border-radius:50%;margin-right:4px;
  vertical-align:middle}
svg.timeline{width:100%;height:auto;background:var(--card);border:1px solid var(--line);
  border-radius:6px}
svg.timeline text{font:11px system-ui,sans-serif;fill:var(--fg)}
svg.timeline .tick{fill:var(--dim)}
svg.timeline .row-bg:nth-of-type(odd){fill:#f4f6f9}
svg.timeline a:hover text{text-decoration:underline}
ol.warnings{padding-left:22px}
li.warning{margin:3px 0}
li.warning .situation{color:var(--warn);font-weight:600;margin-right:6px}
li.warning .frame{color:var(--dim);margin-right:6px}
.stories{display:grid;grid-template-columns:repeat(auto-fill,minmax(330px,1fr));gap:10px}
article.story{background:var(--card);border:1px solid var(--line);border-radius:6px;
  padding:8px 12px}
article.story:target{outline:3px solid #2457c5}
article.story ol{margin:4px 0 0;padding-left:18px}
article.story .source{color:var(--dim);font-size:11px}
.swatch{display:inline-block;width:11px;height:11px;border-radius:2px;margin-right:6px;vertical-align:-1px}
table.metrics{border-collapse:collapse;background:var(--card)}
table.metrics th,table.metrics td{border:1px solid var(--line);padding:4px 8px;text-align:right}
table.metrics th:first-child,table.metrics td:first-child{text-align:left}
figure.pr{display:inline-block;margin:0 24px 16px 0;vertical-align:top}
table.by-confidence{border-collapse:collapse;background:var(--card);font-size:12px}
table.by-confidence th,table.by-confidence td{border:1px solid var(--line);padding:2px 6px;
  text-align:right}
.note{color:var(--dim);font-size:12px}
.frames{display:grid;grid-template-columns:repeat(auto-fill,minmax(360px,1fr));gap:12px}
figure.thumb{margin:0;background:var(--card);border:1px solid var(--line);border-radius:6px;
  padding:6px}
figure.thumb:target{outline:3px solid #2457c5}
figure.thumb img{width:100%;height:auto;display:block;border-radius:3px}
figure.thumb figcaption{font-size:12px;color:var(--dim);margin-top:4px}
#image-status{color:var(--warn)}
"""

_JS = """
(function(){
  function check(){
    var imgs=Array.prototype.slice.call(document.images);
    var ok=imgs.filter(function(i){return i.complete&&i.naturalWidth>0;}).length;
    document.body.setAttribute('data-images-decoded',ok+'/'+imgs.length);
    var s=document.getElementById('image-status');
    if(s){s.textContent=ok===imgs.length?'':
      (imgs.length-ok)+' of '+imgs.length+' pictures could not be shown.';}
  }
  if(document.readyState==='complete'){check();}else{window.addEventListener('load',check);}
})();
"""


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _nice_step(n: int, target: int = 10) -> int:
    raw = max(n / target, 1)
    mag = 10 ** int(np.floor(np.log10(raw)))
    for m in (1, 2, 5, 10):
        if raw <= m * mag:
            return int(m * mag)
    return int(10 * mag)


@dataclass(frozen=True)
class _Geom:
    first: int
    n: int
    label_w: float = 150.0
    plot_w: float = 860.0
    row_h: float = 18.0
    top: float = 24.0

    def x(self, frame: float) -> float:
        return self.label_w + (frame - self.first) * self.plot_w / max(self.n, 1)

    @property
    def unit(self) -> float:
        return self.plot_w / max(self.n, 1)


def _timeline_svg(run: Run) -> str:
    ids = run.track_ids
    g = _Geom(first=run.first_frame, n=max(len(run.frames), 1))
    width = g.label_w + g.plot_w + 12
    n_rows = len(ids) + 1  # + warnings row
    height = g.top + n_rows * g.row_h + 6
    out = [
        f'<svg class="timeline" id="timeline-svg" viewBox="0 0 {width:.0f} {height:.0f}" '
        f'preserveAspectRatio="xMinYMin meet" role="img" aria-label="track states over time">'
    ]
    # axis
    step = _nice_step(g.n)
    start = int(np.ceil(run.first_frame / step) * step)
    out.append('<g class="axis">')
    for f in range(start, run.last_frame + 1, step):
        x = g.x(f)
        out.append(
            f'<line x1="{x:.1f}" y1="{g.top - 4:.1f}" x2="{x:.1f}" y2="{height - 4:.1f}" '
            f'stroke="#e3e6ec" stroke-width="0.6"/>'
            f'<text class="tick" x="{x:.1f}" y="{g.top - 8:.1f}" text-anchor="middle">{f}</text>'
        )
    out.append(f'<text class="tick" x="4" y="{g.top - 8:.1f}">frame</text></g>')
    classes = run.classes
    by_subject: dict[int, list[Any]] = {}
    for e in run.events:
        if e.args and not isinstance(e.args[0], str):  # a constant subject has no track row
            by_subject.setdefault(int(e.args[0]), []).append(e)
    for k, tid in enumerate(ids):
        y = g.top + k * g.row_h
        label = st.track_label(tid, classes.get(tid))
        colour = st.hex_colour(st.track_rgb(tid))
        out.append(f'<g class="track-row" data-track="{tid}">')
        out.append(
            f'<rect class="row-bg" x="0" y="{y:.1f}" width="{width:.0f}" height="{g.row_h:.1f}" '
            f'fill="{"#f4f6f9" if k % 2 else "#ffffff"}"/>'
        )
        out.append(
            f'<a href="#track-{tid}"><rect x="6" y="{y + 4:.1f}" width="10" height="10" rx="2" '
            f'fill="{colour}"/><text x="22" y="{y + 13:.1f}">{_e(label)}</text></a>'
        )
        for sp in run.spans.get(tid, []):
            out.append(_span_rect(g, y, tid, label, sp, classes))
        for e in by_subject.get(tid, []):
            fill = _EVENT_STYLE.get(e.name, ("#111827", 1))[0]
            cx = g.x(e.frame) + g.unit / 2
            out.append(
                f'<circle class="event" data-event="{_e(e.name)}" '
                f'cx="{cx:.1f}" cy="{y + g.row_h / 2:.1f}" '
                f'r="3.6" fill="{fill}" stroke="#fff" stroke-width="0.8">'
                f"<title>frame {e.frame}: {_e(st.event_sentence(e.name, e.args, classes))}</title>"
                "</circle>"
            )
        out.append("</g>")
    y = g.top + len(ids) * g.row_h
    out.append(
        f'<g class="warning-row"><text x="22" y="{y + 13:.1f}" fill="#d92d2d">warnings</text>'
    )
    for i, w in enumerate(run.warnings):
        if st.is_note(w):
            continue
        f = int(_get(w, "frame", 0))
        cx, cy = g.x(f) + g.unit / 2, y + g.row_h / 2
        out.append(
            f'<a href="#warning-{i}"><path class="warning-mark" '
            f'd="M{cx:.1f} {cy - 5:.1f} L{cx + 5:.1f} {cy:.1f} '
            f'L{cx:.1f} {cy + 5:.1f} L{cx - 5:.1f} {cy:.1f}Z" '
            f'fill="#d92d2d">'
            f"<title>frame {f}: {_e(st.warning_sentence(w))}</title></path></a>"
        )
    out.append("</g></svg>")
    return "".join(out)


def _span_rect(g: _Geom, y: float, tid: int, label: str, sp: Span, classes: dict[int, int]) -> str:
    name = st.STATE_NAMES.get(sp.state, "unknown")
    what = name
    if sp.state == TrackState.HIDDEN and sp.occluder >= 0:
        what = f"hidden behind {st.track_label(sp.occluder, classes.get(sp.occluder))}"
    x = g.x(sp.start)
    w = max((sp.end - sp.start + 1) * g.unit, 1.0)
    return (
        f'<rect class="span {name}" x="{x:.2f}" y="{y + 4:.1f}" width="{w:.2f}" height="10" '
        f'fill="{st.STATE_COLOURS.get(sp.state, "#999")}"><title>{_e(label)}: {_e(what)}, '
        f"{_frames_text(sp.start, sp.end)}</title></rect>"
    )


def _legend() -> str:
    states = "".join(
        f'<span><i style="background:{st.STATE_COLOURS[s]}"></i>{st.STATE_NAMES[s]}</span>'
        for s in (0, 1, 2)
    )
    events = "".join(
        f'<span><b style="background:{c}"></b>{_e(n.replace("_", " "))}</span>'
        for n, (c, _) in _EVENT_STYLE.items()
    )
    return (
        f'<div class="legend">{states}{events}<span><b style="background:#d92d2d;border-radius:0;'
        f'transform:rotate(45deg)"></b>warning</span></div>'
    )


def _warnings_html(run: Run, thumbs: set[int]) -> str:
    notes = [w for w in run.warnings if st.is_note(w)]
    note_html = ""
    if notes:
        note_html = (
            '<p class="note">Not checked: '
            + "; ".join(
                _e(
                    f"{str(_get(n, 'situation', '')).upper()} "
                    f"({_get(n, 'details', {}).get('skipped')})"
                )
                for n in notes
            )
            + "</p>"
        )
    if len(notes) == len(run.warnings):
        return '<p class="no-warnings">No warnings.</p>' + note_html
    items = []
    for i, w in enumerate(run.warnings):
        if st.is_note(w):
            continue
        f = int(_get(w, "frame", 0))
        situation = str(_get(w, "situation", "warning")).upper()
        message = str(_get(w, "message", "") or "")
        objects = _get(w, "objects", ()) or ()
        objs = ", ".join(f"#{o}" if isinstance(o, (int, np.integer)) else str(o) for o in objects)
        frame = f'<a href="#frame-{f}">frame {f}</a>' if f in thumbs else f"frame {f}"
        items.append(
            f'<li class="warning" id="warning-{i}" data-frame="{f}">'
            f'<span class="frame">{frame}</span>'
            f'<span class="situation">{_e(situation)}</span>'
            f'<span class="message">{_e(message)}</span>'
            + (f' <span class="note">({_e(objs)})</span>' if objs else "")
            + "</li>"
        )
    return f'<ol class="warnings">{"".join(items)}</ol>' + note_html


def _stories_html(run: Run) -> str:
    explain = _explain_function()
    parts = []
    for tid in run.track_ids:
        sentences, source = track_story(run, tid, explain)
        label = st.track_label(tid, run.classes.get(tid))
        colour = st.hex_colour(st.track_rgb(tid))
        items = "".join(f"<li>{_e(s)}</li>" for s in sentences)
        parts.append(
            f'<article class="story" id="track-{tid}" data-track="{tid}" data-source="{source}">'
            f'<h3><span class="swatch" style="background:{colour}"></span>{_e(label)}</h3>'
            f"<ol>{items}</ol></article>"
        )
    if not parts:
        return "<p>No tracks.</p>"
    return f'<div class="stories">{"".join(parts)}</div>'


def _metrics_html(metrics: Sequence[tuple[str, Any]]) -> str:
    from sensemaking.evaluation.report import INTEGER_FIELDS

    head = "".join(f"<th>{_e(c)}</th>" for c in METRIC_COLUMNS)
    rows = []
    mode = ""
    for label, m in metrics:
        cells = []
        for c in METRIC_COLUMNS:
            v = m[c]
            cells.append(
                f"<td>{int(v)}</td>" if c in INTEGER_FIELDS else f"<td>{100.0 * float(v):.1f}</td>"
            )
        rows.append(f"<tr><td>{_e(label)}</td>{''.join(cells)}</tr>")
        mode = getattr(m, "idsw_mode", mode)
    return (
        f'<table class="metrics"><thead><tr><th>class</th>{head}</tr></thead>'
        f"<tbody>{''.join(rows)}</tbody></table>"
        '<p class="note">Visible boxes scored with TrackEval rules; percentages except '
        f"counts; ID switches counted the {_e(mode)} way.</p>"
    )


def _thumbnails_html(
    run: Run, frames: list[int], images: Any, video: Any, width: int, first_frame: int | None
) -> str:
    if not frames:
        return "<p>No frames.</p>"
    from sensemaking.viz.render import FrameDrawer, RenderOptions, _source

    source = _source(images, video, first_frame, run)
    try:
        src_size = source.size if source is not None else run.size()
        drawer = FrameDrawer(
            run,
            scale=min(1.0, width / max(src_size[0], 1)),
            options=RenderOptions(caption_lines=3, font_size=11),
            with_images=source is not None,
            size=src_size,
        )
        figures = []
        for f in frames:
            picture = source.get(f, drawer.image_size) if source is not None else None
            im = drawer.draw(f, picture)
            buf = io.BytesIO()
            if im.mode == "P":
                im.save(buf, "PNG", optimize=False, compress_level=9)
                mime = "image/png"
            else:
                im.convert("RGB").save(buf, "JPEG", quality=82)
                mime = "image/jpeg"
            data = base64.b64encode(buf.getvalue()).decode("ascii")
            r = run.by_frame.get(f)
            said = [
                st.event_sentence(e.name, e.args, run.classes) for e in (r.events if r else [])
            ]
            said += [st.warning_sentence(w) for w in run.warnings_at(f) if not st.is_note(w)]
            caption = f"frame {f}" + (": " + "; ".join(said) if said else "")
            figures.append(
                f'<figure class="thumb" id="frame-{f}" data-frame="{f}">'
                f'<img src="data:{mime};base64,{data}" '
                f'width="{im.size[0]}" height="{im.size[1]}" alt="frame {f}">'
                f"<figcaption>{_e(caption)}</figcaption></figure>"
            )
    finally:
        close = getattr(source, "close", None)
        if close is not None:
            close()
    return f'<p id="image-status"></p><div class="frames">{"".join(figures)}</div>'


# public API ------------------------------------------------------------------------------------
def build_report(
    scene: Any,
    *,
    gt: str | os.PathLike[str] | Detections | None = None,
    gt_format: str | None = None,
    images: str | os.PathLike[str] | None = None,
    video: str | os.PathLike[str] | None = None,
    first_frame: int | None = None,
    title: str | None = None,
    warnings: Iterable[Any] | str | None = "auto",
    max_thumbnails: int = 24,
    thumbnail_width: int = 480,
    idsw_mode: str = "trackeval",
) -> str:
    """The report as one HTML string (see the module docstring for its sections).

    Args:
        scene: a Scene, the path of a scene JSON, a list of FrameResult, or a Run.
        gt: ground truth (MOT ``gt.txt`` / KITTI ``label_02`` file, or Detections): adds metrics.
        gt_format: ``"mot"`` or ``"kitti"`` (None: guessed from the file).
        images, video, first_frame: pictures under the thumbnails (see :func:`render_scene`).
        title: page title (default: the sequence name).
        warnings: as in :func:`~sensemaking.viz.render.render_scene`.
        max_thumbnails: at most this many key-frame thumbnails (0: none).
        thumbnail_width: thumbnail width in px.
        idsw_mode: ID-switch rule of the metrics (``"trackeval"`` or ``"kitti_legacy"``).
    """
    run = as_run(scene, warnings=warnings)
    name = run.name or "run"
    title = title or f"sensemaking report: {name}"
    metrics = compute_metrics(run, gt, gt_format, idsw_mode) if gt is not None else None
    curves = explanation_curves(run, gt, gt_format) if gt is not None else ""
    frames = key_frames(run, max_thumbnails) if max_thumbnails > 0 else []
    thumbs = (
        _thumbnails_html(run, frames, images, video, thumbnail_width, first_frame)
        if frames
        else ""
    )
    w, h = run.size()
    n_hidden = sum(1 for e in run.events if e.name == "hides_behind")
    n_warn = sum(1 for w in run.warnings if not st.is_note(w))
    summary = (
        f"{len(run.frames)} frames ({run.first_frame}–{run.last_frame}"
        + (f", {run.fps:g} fps" if run.fps else "")
        + f", {w}×{h} px) · {_count(len(run.track_ids), 'track')} · "
        f"{_count(len(run.events), 'event')} ({_count(n_hidden, 'occlusion')}) · "
        f"{_count(n_warn, 'warning')}"
    )
    nav = [
        '<a href="#timeline">Timeline</a>',
        '<a href="#warnings">Warnings</a>',
        '<a href="#stories">Stories</a>',
    ]
    if metrics is not None:
        nav.append('<a href="#metrics">Metrics</a>')
    if curves:
        nav.append('<a href="#explanations">Explanations</a>')
    if thumbs:
        nav.append('<a href="#frames">Key frames</a>')
    body = [
        f'<header><h1>{_e(title)}</h1><p class="summary">{_e(summary)}</p>'
        f"<nav>{''.join(nav)}</nav></header>",
        f'<section id="timeline"><h2>Timeline</h2>{_legend()}{_timeline_svg(run)}</section>',
        f'<section id="warnings"><h2>Warnings ({n_warn})</h2>'
        f"{_warnings_html(run, set(frames))}</section>",
        f'<section id="stories"><h2>Stories</h2>{_stories_html(run)}</section>',
    ]
    if metrics is not None:
        body.append(f'<section id="metrics"><h2>Metrics</h2>{_metrics_html(metrics)}</section>')
    if curves:
        body.append(
            '<section id="explanations"><h2>Explanations</h2><p class="summary">Precision '
            "(plausible of the decidable) and recall of the events kept at or above each "
            f"confidence, judged against the ground truth (docs/EXPLANATIONS.md).</p>{curves}"
            "</section>"
        )
    if thumbs:
        body.append(f'<section id="frames"><h2>Key frames</h2>{thumbs}</section>')
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{_e(title)}</title><style>{_CSS}</style></head>"
        f"<body><main>{''.join(body)}</main><script>{_JS}</script></body></html>\n"
    )


def write_report(
    scene: Any,
    output: str | os.PathLike[str],
    gt: str | os.PathLike[str] | Detections | None = None,
    **kwargs: Any,
) -> Path:
    """Write :func:`build_report` to ``output`` atomically; returns the path. Keywords as there."""
    from sensemaking.viz._media import usual_mode

    text = build_report(scene, gt=gt, **kwargs)
    with atomic_write(output) as fh:
        fh.write(text)
    usual_mode(Path(output))
    return Path(output)

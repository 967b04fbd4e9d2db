"""The HTML report: sections, stories, key frames, metrics, self-containment, CLI."""

from __future__ import annotations

import base64
import io
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("PIL")
pytest.importorskip("imageio_ffmpeg")

from PIL import Image  # noqa: E402
from test_render import Warn, occlusion_results, occlusion_run  # noqa: E402

from sensemaking.detections import Detections  # noqa: E402
from sensemaking.errors import InputError  # noqa: E402
from sensemaking.viz import report as report_mod  # noqa: E402
from sensemaking.viz._run import as_run  # noqa: E402
from sensemaking.viz.report import (
    build_report,
    fallback_story,
    key_frames,
    track_story,
    write_report,
)  # noqa: E402


@pytest.fixture
def no_explain(monkeypatch: pytest.MonkeyPatch) -> None:
    """Use the event-built stories whether or not sensemaking.reasoning has explain()."""
    monkeypatch.setattr(report_mod, "_explain_function", lambda: None)


def test_report_sections(no_explain: None):
    text = build_report(occlusion_run())
    assert text.startswith("<!DOCTYPE html>")
    assert len(re.findall(r'<g class="track-row" data-track="\d+">', text)) == 3
    assert text.count('class="span hidden"') == 1
    assert text.count('class="span missing"') == 1
    assert 'data-event="hides_behind"' in text
    assert text.count('<li class="warning"') == 1
    assert "#2 cyclist hidden behind #1 car may reappear in front" in text
    assert len(re.findall(r'<article class="story" id="track-\d+"', text)) == 3
    assert 'id="metrics"' not in text


def test_report_is_self_contained():
    text = build_report(occlusion_run())
    assert (
        "http:" not in text
        and "https:" not in text
        and "//" not in re.sub(r"data:[^\"]+", "", text)
    )
    assert "<link" not in text and ' src="data:' in text
    assert not re.search(r'src="(?!data:)', text)


def test_thumbnails_decode(no_explain: None):
    text = build_report(occlusion_run(), thumbnail_width=320)
    uris = re.findall(r'src="data:image/png;base64,([^"]+)"', text)
    frames = re.findall(r'<figure class="thumb" id="frame-(\d+)"', text)
    assert len(uris) == len(frames) >= 4
    assert {"15", "16", "23", "28"} <= set(frames)
    im = Image.open(io.BytesIO(base64.b64decode(uris[0])))
    im.load()
    assert im.size[0] == 320


def test_key_frames_prefer_warnings_and_occlusions():
    run = occlusion_run()
    assert key_frames(run, 1) == [16]  # the warning
    two = key_frames(run, 2)
    assert 16 in two and abs(two[0] - two[1]) >= 40 // 4  # spread out
    assert key_frames(run, 3) == [5, 16, 23]
    frames = key_frames(run, 24)
    assert frames == sorted(frames) and {0, 5, 15, 16, 23, 28} <= set(frames)
    quiet = as_run(occlusion_results()[:10], warnings=None)
    quiet = as_run([r.__class__(r.frame, r.tracks, []) for r in quiet.results], warnings=None)
    assert key_frames(quiet, 24) == [0, 2, 4, 5, 7, 9]


def test_fallback_story_tells_the_occlusion():
    run = occlusion_run()
    story = fallback_story(run, 2)
    assert story[0].startswith(
        "#2 cyclist was tracked from frame 0 to frame 39 (4.0 s), visible in 32 of 40"
    )
    assert "Frame 15: #2 cyclist hides behind #1 car (for 8 frames, 0.8 s)." in story
    assert "Frame 23: #2 cyclist reappears from behind #1 car." in story
    assert any(
        "#3 car is not detected (missing detections) (for 3 frames" in s
        for s in fallback_story(run, 3)
    )
    assert fallback_story(run, 99) == []


def test_story_uses_reasoning_when_available():
    run = occlusion_run()
    seen: list[Any] = []

    def explain(scene: Any, track_id: int) -> list[str]:
        seen.append((scene, track_id))
        return [f"Track {track_id} did things.", "Then more."]

    pytest.importorskip("sensemaking.scene")
    sentences, source = track_story(run, 2, explain)
    assert (sentences, source) == (["Track 2 did things.", "Then more."], "reasoning")
    assert seen[0][0] is run.scene and len(run.scene.tracks) == 3

    def broken(scene: Any, track_id: int) -> str:
        raise KeyError(track_id)

    assert track_story(run, 2, broken)[1] == "events"


def test_metrics_against_ground_truth(no_explain: None):
    from sensemaking.classes import CLASS_IDS

    people = [
        r.__class__(
            r.frame,
            r.tracks.with_(class_id=np.full(len(r.tracks), CLASS_IDS["pedestrian"])),
            r.events,
        )
        for r in occlusion_results()
    ]
    run = as_run(people, warnings=None)
    visible = [r.visible for r in run.results]
    gt = Detections.concatenate(
        [
            Detections(
                xyxy=v.xyxy,
                class_id=np.ones(len(v), int),
                tracker_id=v.tracker_id,
                frame=v.frame + 1,
            )
            for v in visible
        ]
    )
    shifted = as_run(
        [
            r.__class__(r.frame + 1, r.tracks.with_(frame=r.tracks.frame + 1), r.events)
            for r in run.results
        ],
        warnings=None,
        width=800,
        height=300,
    )
    text = build_report(shifted, gt=gt, gt_format="mot", max_thumbnails=0)
    assert '<table class="metrics">' in text and "mot17 pedestrian" in text
    row = re.search(r"<tr><td>mot17 pedestrian</td>(.*?)</tr>", text).group(1)
    cells = re.findall(r"<td>([^<]+)</td>", row)
    assert cells[report_mod.METRIC_COLUMNS.index("MOTA")] == "100.0"
    assert cells[report_mod.METRIC_COLUMNS.index("IDSW")] == "0"
    with pytest.raises(InputError, match="no pedestrian tracks"):
        build_report(occlusion_run(), gt=gt, gt_format="mot", max_thumbnails=0)


def test_write_report_and_cli(tmp_path: Path, no_explain: None):
    from sensemaking.cli import main

    out = write_report(occlusion_run(), tmp_path / "r.html", max_thumbnails=2)
    assert out.read_text(encoding="utf-8").count('<figure class="thumb"') == 2
    assert (out.stat().st_mode & 0o777) != 0o600

    scene_mod = pytest.importorskip("sensemaking.scene")
    rec = scene_mod.SceneRecorder(fps=10.0, image_size=(800, 300))
    for r in occlusion_results():
        rec.add(r)
    rec.scene().save(tmp_path / "scene.json")
    assert (
        main(
            [
                "-q",
                "report",
                str(tmp_path / "scene.json"),
                "--output",
                str(tmp_path / "c.html"),
                "--thumbnails",
                "3",
                "--no-warnings",
                "--title",
                "My run",
            ]
        )
        == 0
    )
    html = (tmp_path / "c.html").read_text(encoding="utf-8")
    assert "<title>My run</title>" in html and html.count('<figure class="thumb"') == 3
    assert (
        main(
            [
                "-q",
                "report",
                str(tmp_path / "scene.json"),
                "--output",
                str(tmp_path / "d.html"),
                "--format",
                "mot",
            ]
        )
        == 2
    )
    assert not (tmp_path / "d.html").exists()


def test_notes_are_listed_apart_from_warnings(no_explain: None):
    note = Warn(3, "BLOCKED_LANE", (), "", {"skipped": "no lanes known"})
    text = build_report(
        as_run(occlusion_results(), warnings=[note], width=800, height=300), max_thumbnails=0
    )
    assert "No warnings." in text and "BLOCKED_LANE (no lanes known)" in text
    assert 'class="warning-mark"' not in text


def test_events_of_a_users_encoding_in_the_report(no_explain: None):
    """Events of a user's encoding may have constants or no arguments: those about a track are
    told on its row and in its story with the constants as they are; the others have no row."""
    from sensemaking.results import Event

    results = occlusion_results()
    results[4].events.extend([Event(4, "foggy", ()), Event(4, "near", (1, "left"))])
    results[5].events.append(Event(5, "weather", ("rain",)))
    text = build_report(as_run(results, width=800, height=300), max_thumbnails=0)
    assert "<title>frame 4: near(1, left)</title>" in text
    assert "<li>Frame 4: near(1, left).</li>" in text
    assert "rain" not in text and "foggy" not in text
    assert len(re.findall(r'<g class="track-row" data-track="\d+">', text)) == 3


def test_report_of_empty_runs(no_explain: None):
    from sensemaking.detections import Detections
    from sensemaking.results import FrameResult

    assert "No tracks." in build_report([])
    trackless = build_report([FrameResult(f, Detections.empty()) for f in range(5)])
    assert "No tracks." in trackless and trackless.count('<figure class="thumb"') == 5


def test_a_hidings_confidence_and_a_late_hiding_are_told(no_explain: None):
    """A hiding's confidence is on its line of the track's events; a late hiding
    (may_hide_behind) is told as such, not as a hiding."""
    from sensemaking.results import Event

    results = occlusion_results()
    results[4].events.extend(
        [Event(4, "hides_behind", (1, 2), 0.65), Event(4, "may_hide_behind", (2, 1), 0.3)]
    )
    text = build_report(as_run(results, width=800, height=300), max_thumbnails=0)
    assert re.search(r"Frame 4: [^<]*hides behind [^<]*\(confidence 0\.65\)", text)
    assert re.search(r"Frame 4: [^<]*may be hiding behind [^<]*\(confidence 0\.30\)", text)


def test_explanations_section_curve_is_the_evaluators_table(no_explain: None):
    """With ground truth, the report judges the run's hidings and draws the precision-recall
    curve: its points are the evaluator's rows for the same run (the hiding behind car #1 is
    a true one: the cyclist is labelled occluded while hidden)."""
    import xml.etree.ElementTree as ET

    from sensemaking.classes import CLASS_IDS
    from sensemaking.evaluation.curves import curve_points
    from sensemaking.evaluation.explanations import GroundTruth, evaluate_explanations
    from sensemaking.results import Event

    ped = CLASS_IDS["pedestrian"]
    shifted = []
    for r in occlusion_results():
        events = [
            Event(e.frame + 1, e.name, e.args, 0.75 if e.name == "hides_behind" else None)
            for e in r.events
        ]
        tracks = r.tracks.with_(frame=r.tracks.frame + 1, class_id=np.full(len(r.tracks), ped))
        shifted.append(r.__class__(r.frame + 1, tracks, events))
    run = as_run(shifted, warnings=None, width=800, height=300)
    rows = []
    for f in range(1, 41):
        x = 150 + (f - 1) * 12
        rows.append((f, 1, [300, 100, 500, 250], 1.0))
        rows.append((f, 2, [x, 120, x + 50, 240], 0.0 if 16 <= f <= 23 else 1.0))
        if f >= 6:
            rows.append((f, 3, [20 + f - 1, 40, 100 + f - 1, 90], 1.0))
    gt = Detections(
        xyxy=np.array([r[2] for r in rows], dtype=float),
        class_id=np.ones(len(rows), int),
        tracker_id=[r[1] for r in rows],
        frame=[r[0] for r in rows],
        data={"visibility": np.array([r[3] for r in rows])},
    )
    text = build_report(run, gt=gt, gt_format="mot", max_thumbnails=0)
    assert '<section id="explanations">' in text and 'href="#explanations"' in text
    assert "http:" not in text and "//" not in text  # still self-contained
    svg = re.search(r'<figure class="pr" data-kind="hides_behind">(<svg.*?</svg>)', text, re.S)
    assert svg is not None
    points = [
        (
            float(c.get("data-threshold")),
            float(c.get("data-recall")),
            float(c.get("data-precision")),
        )
        for c in ET.fromstring(svg.group(1)).iter("circle")
    ]
    truth = GroundTruth.from_mot(gt, image_size=(800, 300), fps=30.0)  # the report's, fps unknown
    tracks = report_mod._run_tracks(run)
    judged = evaluate_explanations(truth, tracks, run.events).summary()["events"]["hides_behind"]
    assert points == curve_points(judged["by_confidence"])
    by = {t: (r, p) for t, r, p in points}
    assert by[0.7] == (1.0, 1.0) and 0.8 not in by  # kept up to its confidence 0.75
    # without hidings there is no section
    plain = build_report(occlusion_run(), max_thumbnails=0)
    assert 'id="explanations"' not in plain

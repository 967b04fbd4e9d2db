"""The built-in example: the paper's Figure 1 (a car turns across a cyclist, who disappears
behind it and reappears), tracked with abduction and explained in sentences."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from sensemaking.classes import class_name
from sensemaking.errors import MissingExtraError
from sensemaking.io.kitti import write_kitti
from sensemaking.pipeline import Pipeline
from sensemaking.results import Event, FrameResult
from sensemaking.sinks import EventsSink, Sink, TracksSink, WarningsSink
from sensemaking.synthetic import figure1_scene
from sensemaking.tracker import Tracker, TrackerConfig
from sensemaking.vocabulary import event_sentence

__all__ = ["DemoResult", "run_demo", "describe_event"]

log = logging.getLogger(__name__)


def describe_event(event: Event, classes: dict[int, int], fps: float) -> str:
    """One readable sentence, e.g. ``frame 21 (2.1 s): cyclist #2 hides behind car #1``."""
    names = [
        f"{class_name(classes.get(a, 0) if isinstance(a, int) else 0)} #{a}" for a in event.args
    ]
    phrase = event_sentence(event.name, names)
    return f"frame {event.frame} ({event.frame / fps:.1f} s): {phrase}"


@dataclass
class DemoResult:
    """What the demo produced: the frame results, warnings, and the files written."""

    results: list[FrameResult]
    events: list[Event]
    warnings: list = field(default_factory=list)
    files: dict[str, Path] = field(default_factory=dict)
    sentences: list[str] = field(default_factory=list)


def run_demo(
    output_dir: str | Path, *, render: bool = True, echo: Callable[[str], None] = lambda s: None
) -> DemoResult:
    """Track the Figure 1 scene, explain it, and write every output into ``output_dir``.

    Files: ``detections.txt`` (input, KITTI format), ``tracks.txt`` (KITTI results),
    ``events.jsonl``, ``warnings.jsonl``, ``scene.json``; with the ``viz`` extra also
    ``demo.gif`` and ``report.html``.
    """
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    synthetic = figure1_scene()
    size = (synthetic.width, synthetic.height)
    config = TrackerConfig.for_dataset("kitti", fps=synthetic.fps, image_size=size)
    tracker = Tracker(config)

    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.scene import SceneRecorder

    recorder = SceneRecorder(
        fps=config.fps, image_size=size, metadata={"source": "sensemaking demo (Figure 1)"}
    )
    monitor = SituationMonitor(fps=config.fps, image_size=size)
    files = {
        "detections": out / "detections.txt",
        "tracks": out / "tracks.txt",
        "events": out / "events.jsonl",
        "warnings": out / "warnings.jsonl",
        "scene": out / "scene.json",
    }
    results: list[FrameResult] = []
    warnings: list = []
    sinks: list[Sink] = [
        TracksSink(files["tracks"], "kitti"),
        EventsSink(files["events"]),
        WarningsSink(files["warnings"]),
    ]
    with Pipeline(tracker, recorder, monitor, sinks) as pipe:
        for f, dets in synthetic.frames():
            step = pipe.step(f, dets)
            results.append(step.result)
            warnings.extend(step.warnings)
    scene = recorder.scene()

    events = [e for r in results for e in r.events]
    classes = {
        int(t): int(c)
        for r in results
        for t, c in zip(r.tracks.tracker_id, r.tracks.class_id, strict=True)
    }
    sentences = [describe_event(e, classes, config.fps) for e in events]
    write_kitti(files["detections"], synthetic.detections)
    scene.save(files["scene"])

    echo("What happened (abduced events):")
    for s in sentences:
        echo("  " + s)
    from sensemaking.reasoning.questions import explain

    echo("The story of each track:")
    for line in explain(scene):
        echo("  " + line)
    echo("Warnings:")
    said = [w for w in warnings if w.objects]  # without objects: a situation not checked
    for w in said:
        echo(f"  frame {w.frame}: {w.situation} {list(w.objects)}: {w.message}")
    if not said:
        echo("  (none)")
    for w in warnings:
        if not w.objects:
            echo(f"  (not checked: {w.message})")
    if render:
        try:
            from sensemaking.viz.render import render_scene
            from sensemaking.viz.report import write_report

            files["gif"] = out / "demo.gif"
            render_scene(scene, files["gif"], warnings=warnings)
            files["report"] = out / "report.html"
            write_report(scene, files["report"], warnings=warnings)
        except (MissingExtraError, ImportError) as exc:
            echo(f"(not rendered: {exc})")
    echo("Files:")
    for k, p in files.items():
        echo(f"  {k:10s} {p}")
    return DemoResult(
        results=results, events=events, warnings=warnings, files=files, sentences=sentences
    )

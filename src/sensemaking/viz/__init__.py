"""Pictures of a run: rendered videos / GIFs / PNG frames and a self-contained HTML report.

Needs the ``viz`` extra (Pillow, imageio, imageio-ffmpeg); nothing is imported until used::

    from sensemaking.viz import render_scene, write_report
    render_scene("scene.json", "out.gif")
    write_report("scene.json", "report.html")
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__all__ = [
    "render_scene",
    "render_frame",
    "RenderOptions",
    "FrameDrawer",
    "write_report",
    "build_report",
    "Run",
    "as_run",
    "read_warnings",
]

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.viz._run import Run, as_run, read_warnings
    from sensemaking.viz.render import FrameDrawer, RenderOptions, render_frame, render_scene
    from sensemaking.viz.report import build_report, write_report

_WHERE = {
    "render_scene": "render",
    "render_frame": "render",
    "RenderOptions": "render",
    "FrameDrawer": "render",
    "write_report": "report",
    "build_report": "report",
    "Run": "_run",
    "as_run": "_run",
    "read_warnings": "_run",
}


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'sensemaking.viz' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(f"sensemaking.viz.{module}"), name)

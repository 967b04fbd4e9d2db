"""sensemaking: online abductive visual sensemaking (ASP-based tracking with explanations).

Import what you need from the submodules; nothing heavy happens at import time::

    from sensemaking import Detections, Tracker
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"
__all__ = ["Detections", "Tracker", "TrackerConfig", "FrameResult", "Event", "__version__"]

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.detections import Detections
    from sensemaking.tracker import Event, FrameResult, Tracker, TrackerConfig


def __getattr__(name: str) -> Any:
    if name == "Detections":
        from sensemaking.detections import Detections

        return Detections
    if name in ("Tracker", "TrackerConfig", "FrameResult", "Event"):
        from sensemaking import tracker

        return getattr(tracker, name)
    raise AttributeError(f"module 'sensemaking' has no attribute {name!r}")

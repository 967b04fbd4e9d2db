"""ROS 2 bags and MCAP: detections in, tracks, events and warnings out, live in Foxglove.

Behind the extra ``sensemaking[ros]`` (``rosbags`` reads bags and CDR without ROS; ``mcap``
writes the output file; ``websockets`` serves the live view). Importing this package needs none
of them; each module that does raises :class:`~sensemaking.errors.MissingExtraError` naming the
extra. See docs/ROS.md for the message types, the class table, stamps and the channels written.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sensemaking.errors import require

__all__ = ["EXTRA", "is_bag", "is_mcap_output", "require_ros"]

#: the extra that brings the dependencies of this package
EXTRA = "ros"


def is_bag(path: Path) -> bool:
    """True for what this package reads: an ``.mcap`` or ``.db3`` file, or a ROS 2 bag folder
    (``metadata.yaml`` beside its storage files)."""
    p = Path(path)
    if p.is_dir():
        return (p / "metadata.yaml").is_file()
    return p.suffix.lower() in (".mcap", ".db3")


def is_mcap_output(path: Path | None) -> bool:
    """True when an output path names an MCAP file (written by :class:`McapSink`)."""
    return path is not None and Path(path).suffix.lower() == ".mcap"


def require_ros(module: str) -> Any:
    """Import a dependency of the ``ros`` extra, or raise an ImportError naming the extra."""
    return require(module, EXTRA)

"""The benchmark runner: our tracker and its peers on KITTI / MOT17 / MOT15, evaluated the same
way.

Submodules (imported lazily; nothing happens at import time):

- :mod:`~sensemaking.benchmark.datasets` finds every benchmark in a data folder.
- :mod:`~sensemaking.benchmark.peers` wraps our tracker and SORT / ByteTrack / OC-SORT from
  the ``trackers`` package (the ``benchmark`` extra) behind one per-frame interface.
- :mod:`~sensemaking.benchmark.runner` runs every tracker on every benchmark and evaluates it.
- :mod:`~sensemaking.benchmark.report` writes ``docs/BENCHMARKS.md`` and its JSON twin.
"""

from __future__ import annotations

__all__ = ["datasets", "peers", "runner", "report"]

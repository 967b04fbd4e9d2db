"""The benchmark runner: our tracker and its peers on KITTI / MOT17 / MOT15, evaluated the same
way.

Submodules (imported lazily; nothing happens at import time):

- :mod:`~sensemaking.benchmark.datasets` finds every benchmark in a data folder.
- :mod:`~sensemaking.benchmark.peers` wraps our tracker and SORT / ByteTrack / OC-SORT from
  the ``trackers`` package (the ``benchmark`` extra) behind one per-frame interface.
- :mod:`~sensemaking.benchmark.sequences` our parameters, one tracking pass, the result files.
- :mod:`~sensemaking.benchmark.runner` runs every tracker on every benchmark and evaluates it;
  :mod:`~sensemaking.benchmark.crossval` cross-validates our parameters.
- :mod:`~sensemaking.benchmark.summary` the overview table and the JSON of a run.

The project's own pages (``docs/BENCHMARKS.md`` with its acceptance targets,
``docs/PARAMETERS.md``) are rendered outside the package, by ``benchmarks/benchmark_report.py``.
"""

from __future__ import annotations

__all__ = ["datasets", "peers", "sequences", "runner", "crossval", "summary"]

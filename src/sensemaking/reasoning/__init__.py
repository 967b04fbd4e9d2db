"""Reasoning over tracker output: spatial relations, the scene's question answering,
anticipation of hidden objects, and online warnings about safety-critical situations.

Submodules (imported on demand, nothing happens at import time):

* :mod:`~sensemaking.reasoning.relations` -- interval / rectangle algebra, qualitative motion.
* :mod:`~sensemaking.reasoning.context` -- ego corridor, lanes, semantic segmentation.
* :mod:`~sensemaking.reasoning.questions` -- ``ask(scene, query)`` and ``explain(scene)``.
* :mod:`~sensemaking.reasoning.anticipation` -- where and when a hidden object reappears.
* :mod:`~sensemaking.reasoning.situations` -- the situation encoding and the ``Warning`` type.
* :mod:`~sensemaking.reasoning.online` -- ``SituationMonitor.update(result) -> warnings``.

The monitor's per-frame modules (:data:`COMPILED`) are compiled with mypyc at install time when
mypyc and a C compiler are present (setup.py); :func:`compiled` says whether they were. Compiled
classes cannot be subclassed from Python code, and patching a function there does not reach the
compiled callers; ``SENSEMAKING_PURE_PYTHON=1 pip install ...`` installs the plain sources.
"""

from __future__ import annotations

import importlib
import importlib.machinery

#: modules that setup.py compiles with mypyc when it can (the per-frame path of the monitor)
COMPILED: tuple[str, ...] = (
    "sensemaking.reasoning.online",
    "sensemaking.reasoning.relations",
    "sensemaking.reasoning.anticipation",
)


def compiled() -> dict[str, bool]:
    """Which of :data:`COMPILED` are installed compiled (True) or as pure Python (False).

    Imports them. The results are the same either way; the compiled ones are about twice as
    fast. A pure-Python install comes from ``SENSEMAKING_PURE_PYTHON=1``, or from a machine
    without mypyc or a C compiler at install time (``pip install -v`` shows why).
    """
    suffixes = tuple(importlib.machinery.EXTENSION_SUFFIXES)
    return {name: (getattr(importlib.import_module(name), "__file__", None) or "").endswith(suffixes)
            for name in COMPILED}

"""Build hook: compile the online monitor's per-frame modules with mypyc, else stay pure Python.

Everything else is in pyproject.toml. The modules below run every frame beside the tracker
(``benchmarks/reasoning_overhead.py`` measures what they add); compiled with mypyc they take about
half the time, with the same results (the same source: the tests run on whichever is installed).
When mypyc or a C compiler is missing, or ``SENSEMAKING_PURE_PYTHON=1`` is set, the package
installs as pure Python and works the same, only slower; ``sensemaking.reasoning.compiled()``
says which modules are compiled.
"""

from __future__ import annotations

import os
import sys

from setuptools import setup

#: compiled with mypyc when possible (keep in step with sensemaking.reasoning.COMPILED)
COMPILED = [
    "src/sensemaking/reasoning/online.py",
    "src/sensemaking/reasoning/relations.py",
    "src/sensemaking/reasoning/anticipation.py",
]


def _ext_modules() -> list:
    if os.environ.get("SENSEMAKING_PURE_PYTHON", "") not in ("", "0"):
        print("sensemaking: SENSEMAKING_PURE_PYTHON is set, installing pure Python", file=sys.stderr)
        return []
    try:
        from mypyc.build import mypycify
    except ImportError as exc:
        print(f"sensemaking: mypyc is not available ({exc}), installing pure Python", file=sys.stderr)
        return []
    try:
        # the other modules are only read for their types
        extensions = mypycify(["--follow-imports=silent", *COMPILED], opt_level="3")
    except (Exception, SystemExit) as exc:  # mypy reports type errors by exiting
        print(f"sensemaking: mypyc could not compile ({exc!r}), installing pure Python", file=sys.stderr)
        return []
    for ext in extensions:
        ext.optional = True  # a failed C build leaves the pure-Python module in place
    return extensions


setup(ext_modules=_ext_modules())

"""Run the whole benchmark and write docs/BENCHMARKS.md.

Usage: ``python benchmarks/run_all.py [options]``.

A thin wrapper around ``sensemaking benchmark`` (same options; see ``--help``).
"""

from __future__ import annotations

import sys

from sensemaking.cli import main

if __name__ == "__main__":
    sys.exit(main(["benchmark", *sys.argv[1:]]))

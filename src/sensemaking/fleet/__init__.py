"""Fleet scale: many sequences tracked as Ray tasks into a Parquet archive, queried with DuckDB.

::

    from sensemaking.fleet.specs import find_sequences
    from sensemaking.fleet.batch import run_batch
    from sensemaking.fleet.query import run_query, NAMED_QUERIES
    from sensemaking.fleet.archive import load_scene

    specs = find_sequences(["../shared/data"])
    summary = run_batch(specs, "archive", workers=2)
    table = run_query("archive", "warnings-by-lead")
    scene = load_scene("archive", "kitti-rrc-car", "0005")

Ray, pyarrow and DuckDB come with the ``fleet`` extra (``pip install 'sensemaking[fleet]'``);
discovery and the per-sequence run (:mod:`~sensemaking.fleet.specs`,
:mod:`~sensemaking.fleet.run`) need only the core. The archive layout and every table's
columns are in ``docs/FLEET.md``.
"""

from __future__ import annotations

__all__: list[str] = []

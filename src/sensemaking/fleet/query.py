"""Questions over an archive in SQL (DuckDB): the tables as views, plus named queries.

Every table of the archive (``tracks``, ``events``, ``warnings``, ``metrics``, ``runs``; columns
in ``docs/FLEET.md``) is a view over its Parquet files, so any DuckDB SQL works::

    sensemaking query ARCHIVE "SELECT situation, count(*) FROM warnings GROUP BY ALL"

A named query is a name and its arguments instead of SQL (``NAMED_QUERIES``)::

    sensemaking query ARCHIVE warnings-by-lead
    sensemaking query ARCHIVE late-hidden-warnings cyclist 1.0
    sensemaking query ARCHIVE compare baseline no-abduction

A *run* in ``compare`` and ``metrics-across-runs`` is a parameter set: it is named by its
``label`` (``batch --label``), its ``params_id`` (or a prefix) or the ``run_id`` of a batch.

The SQL is untrusted (``docs/SECURITY.md``): one ``SELECT`` (or ``EXPLAIN``) statement, on a
connection that reads only the archive's Parquet files (DuckDB's ``allowed_paths``, external
access off, no extension installed or loaded, no spilling to disk, a memory limit, the
configuration locked), with at most ``max_rows`` rows fetched (in chunks, as they stream) and
Ctrl-C / SIGTERM interrupting DuckDB at once.
"""

from __future__ import annotations

import csv
import io
import json
import logging
import math
import os
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sensemaking.errors import InputError, SensemakingError, require
from sensemaking.fleet.archive import TABLES, schemas

_LOG = logging.getLogger(__name__)

__all__ = [
    "NamedQuery",
    "NAMED_QUERIES",
    "QueryResult",
    "connect",
    "run_query",
    "DEFAULT_MAX_ROWS",
    "DEFAULT_MEMORY_MB",
]

#: rows an answer may have (more: an error that says to narrow the query)
DEFAULT_MAX_ROWS = 200_000
#: DuckDB's memory limit for one query (MB); nothing spills to disk
DEFAULT_MEMORY_MB = 1024
#: statements a query may be: reading only
_READ_STATEMENTS = ("SELECT", "EXPLAIN")
_FETCH = 10_000

_RUN = "coalesce(r.label, r.params_id)"


@dataclass(frozen=True)
class NamedQuery:
    """A question kept under a name: SQL with ``$1, $2, ...`` for its arguments."""

    name: str
    help: str
    sql: str
    args: tuple[tuple[str, str | None], ...] = ()  # (name, default or None when required)

    @property
    def usage(self) -> str:
        parts = [self.name] + [f"{a}" if d is None else f"[{a}={d}]" for a, d in self.args]
        return " ".join(parts)


_LEAD_BUCKET = """CASE WHEN w.lead_s IS NULL THEN 'none'
         WHEN w.lead_s < 0.5 THEN '<0.5 s' WHEN w.lead_s < 1 THEN '0.5-1 s'
         WHEN w.lead_s < 2 THEN '1-2 s' ELSE '>=2 s' END"""

NAMED_QUERIES: dict[str, NamedQuery] = {
    q.name: q
    for q in (
        NamedQuery(
            "warnings-by-lead",
            "warnings by situation, class of the object and lead time (HIDDEN_ENTITY: seconds "
            "between the warning and the anticipated reappearance), per run",
            f"""SELECT {_RUN} AS run, w.situation, w.track_class AS class,
       {_LEAD_BUCKET} AS lead_time, count(*) AS warnings,
       count(DISTINCT w.dataset || '/' || w.sequence) AS sequences,
       round(min(w.lead_s), 2) AS min_lead_s
FROM warnings w JOIN runs r USING (dataset, sequence, key)
GROUP BY ALL ORDER BY run, situation, class, min(coalesce(w.lead_s, 1e9))""",
        ),
        NamedQuery(
            "late-hidden-warnings",
            "HIDDEN_ENTITY warnings about an object of CLASS (any: all) anticipated to reappear "
            "less than SECONDS ahead",
            f"""SELECT w.dataset, w.sequence, {_RUN} AS run, w.frame, round(w.time_s, 2) AS time_s,
       w.track_id, w.track_class AS class, w.other_id AS occluder, w.other_class AS occluder_class,
       w.lead_s
FROM warnings w JOIN runs r USING (dataset, sequence, key)
WHERE w.situation = 'HIDDEN_ENTITY' AND w.lead_s < CAST($2 AS DOUBLE)
  AND ($1 = 'any' OR w.track_class = $1)
ORDER BY w.lead_s, w.dataset, w.sequence, w.frame""",
            (("CLASS", "any"), ("SECONDS", "1.0")),
        ),
        NamedQuery(
            "identity-losses",
            "tracks the tracker gave up (an `ends` event, not leaving the view) while hidden or "
            "missing, by their class and the class of the occluder they were last hidden behind, "
            "per run",
            f"""WITH last AS (
  SELECT dataset, sequence, key, track_id, arg_max(state, frame) AS state,
         arg_max(occluder, frame) AS occluder
  FROM tracks GROUP BY ALL),
cls AS (SELECT dataset, sequence, key, track_id, mode(object_class) AS object_class
        FROM tracks GROUP BY ALL),
ended AS (SELECT DISTINCT dataset, sequence, key, track_id FROM events WHERE event = 'ends')
SELECT {_RUN} AS run, c.object_class AS class,
       CASE WHEN l.state = 'hidden' THEN coalesce(o.object_class, 'unknown')
            ELSE '(none: missing detections)' END AS occluder_class,
       count(*) AS losses, count(DISTINCT l.dataset || '/' || l.sequence) AS sequences
FROM last l JOIN ended e USING (dataset, sequence, key, track_id)
JOIN cls c USING (dataset, sequence, key, track_id)
LEFT JOIN cls o ON o.dataset = l.dataset AND o.sequence = l.sequence AND o.key = l.key
                AND o.track_id = l.occluder AND l.state = 'hidden'
JOIN runs r ON r.dataset = l.dataset AND r.sequence = l.sequence AND r.key = l.key
WHERE l.state IN ('hidden', 'missing')
GROUP BY ALL ORDER BY run, losses DESC, class, occluder_class""",
        ),
        NamedQuery(
            "metrics-across-runs",
            "per sequence: the scores of every run (percent; IDSW counts), oldest first",
            f"""SELECT m.dataset, m.sequence, {_RUN} AS run, r.software_version AS version,
       strftime(r.ended, '%Y-%m-%d %H:%M') AS ended,
       round(100 * m.HOTA, 2) AS HOTA, round(100 * m.MOTA, 2) AS MOTA,
       round(100 * m.IDF1, 2) AS IDF1, CAST(m.IDSW AS BIGINT) AS IDSW, m.warnings,
       round(m.ms_per_frame, 2) AS ms_per_frame
FROM metrics m JOIN runs r USING (dataset, sequence, key)
ORDER BY m.dataset, m.sequence, r.ended""",
        ),
        NamedQuery(
            "compare",
            "two runs compared per sequence (B minus A): HOTA and IDF1 in points, ID switches, "
            "warnings and events",
            """WITH sel AS (
  SELECT m.*, r.label, r.params_id, r.run_id, r.ended FROM metrics m
  JOIN runs r USING (dataset, sequence, key)),
a AS (SELECT * FROM sel WHERE label = $1 OR params_id LIKE $1 || '%' OR run_id = $1
      QUALIFY row_number() OVER (PARTITION BY dataset, sequence ORDER BY ended DESC) = 1),
b AS (SELECT * FROM sel WHERE label = $2 OR params_id LIKE $2 || '%' OR run_id = $2
      QUALIFY row_number() OVER (PARTITION BY dataset, sequence ORDER BY ended DESC) = 1)
SELECT dataset, sequence,
       round(100 * a.HOTA, 2) AS HOTA_a, round(100 * b.HOTA, 2) AS HOTA_b,
       round(100 * (b.HOTA - a.HOTA), 2) AS d_HOTA,
       round(100 * (b.IDF1 - a.IDF1), 2) AS d_IDF1,
       CAST(a.IDSW AS BIGINT) AS IDSW_a, CAST(b.IDSW AS BIGINT) AS IDSW_b,
       a.warnings AS warnings_a, b.warnings AS warnings_b, a.events AS events_a,
       b.events AS events_b
FROM a JOIN b USING (dataset, sequence) ORDER BY dataset, sequence""",
            (("A", None), ("B", None)),
        ),
        NamedQuery(
            "sequences",
            "every archived result: status, run, frames, seconds, error",
            f"""SELECT r.dataset, r.sequence, r.class, {_RUN} AS run, r.status, m.frames,
       round(r.seconds, 2) AS seconds, r.error
FROM runs r LEFT JOIN metrics m USING (dataset, sequence, key)
ORDER BY r.status DESC, r.dataset, r.sequence""",
        ),
    )
}


@dataclass
class QueryResult:
    """Columns and rows of an answer."""

    columns: list[str]
    rows: list[tuple[Any, ...]]

    def format(self, fmt: str = "table") -> str:
        """``table`` (aligned text), ``csv`` or ``json`` (a list of objects)."""
        if fmt == "json":
            return (
                json.dumps(
                    [
                        dict(zip(self.columns, (_plain(v) for v in row), strict=True))
                        for row in self.rows
                    ],
                    indent=1,
                    default=str,
                )
                + "\n"
            )
        if fmt == "csv":
            out = io.StringIO()
            w = csv.writer(out, lineterminator="\n")
            w.writerow(self.columns)
            for row in self.rows:
                w.writerow(["" if v is None else _plain(v) for v in row])
            return out.getvalue()
        if fmt != "table":
            raise ValueError(f"unknown format {fmt!r}")
        cells = [self.columns] + [[_cell(v) for v in row] for row in self.rows]
        widths = [max(len(r[i]) for r in cells) for i in range(len(self.columns))]
        lines = [
            "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in cells
        ]
        lines.insert(1, "  ".join("-" * w for w in widths))
        lines.append(f"({len(self.rows)} row{'s' if len(self.rows) != 1 else ''})")
        return "\n".join(lines) + "\n"


def _plain(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if hasattr(v, "isoformat"):
        return v.isoformat()
    return v


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def _glob_escape(path: Path) -> str:
    """``path`` as a DuckDB glob that matches only itself (``[``, ``*``, ``?`` as classes)."""
    return "".join(f"[{c}]" if c in "[*?" else c for c in str(path))


def _sql_list(paths: Sequence[Path], *, glob: bool = True) -> str:
    """A SQL list of file paths; read literally (``glob`` escaped) unless ``glob`` is False."""
    text = [_glob_escape(p) if glob else str(p) for p in paths]
    return "[" + ", ".join("'" + t.replace("'", "''") + "'" for t in text) + "]"


def connect(root: str | Path, *, memory_mb: int = DEFAULT_MEMORY_MB) -> Any:
    """A DuckDB connection with one view per table of the archive at ``root``: the segments
    (:func:`~sensemaking.fleet.archive.compact`), less their members replaced since, plus the
    folders not in a segment yet.

    Raises:
        InputError: ``root`` is not an archive.
    """
    from sensemaking.fleet.archive import _folder_id, check_marker, published, segment_members

    duckdb = require("duckdb", "fleet")
    pa = require("pyarrow", "fleet")
    root = Path(os.path.realpath(root))  # Path.resolve raises on a symlink loop
    if not (root / "_fleet.json").is_file():
        raise InputError(
            "not a sensemaking archive (no _fleet.json; write one with "
            "`sensemaking batch --archive DIR`)",
            root,
        )
    check_marker(root)
    current = {}
    for dataset, sequence, key, folder in published(root):
        current[(dataset, sequence, key, *_folder_id(folder))] = folder
    segments: list[tuple[Path, list[tuple]]] = []  # (segment, its members replaced since)
    in_segment: set[tuple] = set()
    for seg, m in segment_members(root):
        stale: list[tuple] = []
        columns = (m["dataset"], m["sequence"], m["key"], m["ino"], m["mtime_ns"])
        for member in zip(*columns, strict=True):
            (in_segment.add if member in current else stale.append)(member)
        segments.append((seg, stale))
    loose = [folder for member, folder in current.items() if member not in in_segment]
    con = duckdb.connect(
        ":memory:",
        config={
            "autoinstall_known_extensions": False,
            "autoload_known_extensions": False,
            "temp_directory": "",  # no spilling: the memory limit is the bound
            # past 2**40 MB no machine's memory, and past 2**44 DuckDB refuses the setting
            "memory_limit": f"{min(int(memory_mb), 2**40)}MB",
        },
    )
    readable: list[Path] = []
    for i, (_, stale) in enumerate(segments):
        if stale:
            con.register(
                f"_stale{i}",
                pa.table(
                    {
                        "dataset": [m[0] for m in stale],
                        "sequence": [m[1] for m in stale],
                        "key": [m[2] for m in stale],
                    }
                ),
            )
    for table in TABLES:
        con.register(f"_empty_{table}", pa.Table.from_pylist([], schema=schemas()[table]))
        parts = [f"SELECT * FROM _empty_{table}"]
        plain = [seg / f"{table}.parquet" for seg, stale in segments if not stale]
        if plain:
            parts.append(f"SELECT * FROM read_parquet({_sql_list(plain)})")
        for i, (seg, stale) in enumerate(segments):
            if stale:
                parts.append(
                    f"SELECT * FROM read_parquet({_sql_list([seg / f'{table}.parquet'])}) "
                    f"ANTI JOIN _stale{i} USING (dataset, sequence, key)"
                )
        files = [f / f"{table}.parquet" for f in loose if (f / f"{table}.parquet").is_file()]
        if files:
            parts.append(f"SELECT * FROM read_parquet({_sql_list(files)})")
        try:
            con.execute(f"CREATE VIEW {table} AS " + " UNION ALL ".join(parts))
        except duckdb.Error as exc:  # a truncated or foreign file: the view reads its footer
            first = " ".join(str(exc).split("LINE 1:")[0].split())
            raise InputError(
                f"damaged archive ({first}); the next `sensemaking batch` on it runs the "
                "sequence again",
                root,
            ) from None
        readable += [seg / f"{table}.parquet" for seg, _ in segments] + files
    # the views read these files and nothing else can be read, written, installed or changed
    # DuckDB checks the path as written (escaped) and each file it expands to
    allowed = _sql_list(readable, glob=False)[:-1] + ", " + _sql_list(readable)[1:]
    con.execute(f"SET allowed_paths = {allowed if readable else '[]'}")
    con.execute("SET enable_external_access = false")
    con.execute("SET lock_configuration = true")
    return con


def _statement_check(con: Any, sql: str) -> None:
    """Refuse SQL that is not one reading statement (COPY, ATTACH, SET, INSTALL, CREATE ...)."""
    duckdb = require("duckdb", "fleet")
    try:
        statements = con.extract_statements(sql)
    except duckdb.Error as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"query failed: {first}") from None
    if len(statements) != 1:
        raise InputError(f"give one SQL statement, not {len(statements)}")
    kind = str(statements[0].type).rsplit(".", 1)[-1]
    if kind not in _READ_STATEMENTS:
        raise InputError(
            f"only reading SQL is answered (SELECT, WITH ... SELECT, EXPLAIN), not {kind}"
        )


def _fetch(con: Any, sql: str, params: list[str], max_rows: int) -> tuple[list[str], list]:
    """Run ``sql`` in a worker thread, fetching in chunks up to ``max_rows`` rows; Ctrl-C or
    SIGTERM (KeyboardInterrupt in the main thread) interrupts DuckDB and is raised again."""
    out: dict[str, Any] = {}

    def work() -> None:
        cur = None
        try:
            cur = con.execute(sql, params) if params else con.execute(sql)
            columns = [d[0] for d in cur.description] if cur.description else []
            rows: list[tuple[Any, ...]] = []
            while columns:
                chunk = cur.fetchmany(_FETCH)
                if not chunk:
                    break
                rows.extend(chunk)
                if len(rows) > max_rows:
                    out["over"] = True
                    break
            out["result"] = (columns, rows[:max_rows])
        except BaseException as exc:  # noqa: BLE001 - handed to the main thread
            # without its traceback: the frames would keep the streaming result (and so the
            # connection) busy
            out["error"] = exc.with_traceback(None)
        finally:
            if cur is not None:
                cur.close()

    worker = threading.Thread(target=work, name="sensemaking-query", daemon=True)
    worker.start()
    _LOG.info("query running (Ctrl-C or SIGTERM stops it)")
    try:
        while worker.is_alive():
            worker.join(0.1)
    except KeyboardInterrupt:
        # DuckDB checks for an interrupt between its tasks: ask until the worker stops
        while worker.is_alive():
            con.interrupt()
            worker.join(0.2)
        raise
    if "error" in out:
        raise out["error"]
    if out.get("over"):
        raise InputError(
            f"the answer has more than {max_rows} rows (--max-rows); narrow it with WHERE, "
            "GROUP BY or LIMIT"
        )
    return out["result"]


def run_query(
    root: str | Path,
    query: str,
    args: Sequence[str] = (),
    *,
    max_rows: int = DEFAULT_MAX_ROWS,
    memory_mb: int = DEFAULT_MEMORY_MB,
) -> QueryResult:
    """Answer SQL, or a named query with its arguments, over the archive at ``root``: at most
    ``max_rows`` rows, DuckDB within ``memory_mb`` MB.

    Raises:
        InputError: not an archive, wrong arguments for a named query, SQL that is not one
            reading statement, more rows than ``max_rows``, or DuckDB rejects the SQL (its
            message, one line: a file outside the archive, the memory limit ...).
    """
    duckdb = require("duckdb", "fleet")
    named = NAMED_QUERIES.get(query.strip())
    params: list[str] = []
    if named is not None:
        if len(args) > len(named.args) or len(args) < sum(d is None for _, d in named.args):
            raise InputError(f"usage: {named.usage}")
        params = list(args) + [d for _, d in named.args[len(args) :]]  # type: ignore[misc]
        sql = named.sql
    else:
        if args:
            raise InputError(
                f"{query.split()[0] if query.split() else query!r} is not a named query "
                f"({', '.join(NAMED_QUERIES)}); give SQL as one argument"
            )
        sql = query
    con = connect(root, memory_mb=memory_mb)
    try:
        _statement_check(con, sql)
        columns, rows = _fetch(con, sql, params, max_rows)
    except duckdb.Error as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"query failed: {first}") from None
    except SensemakingError:
        raise
    finally:
        try:
            con.close()
        except duckdb.Error:  # still busy after an interrupt: the process is ending anyway
            pass
    return QueryResult(columns, rows)

"""``sensemaking query ARCHIVE SQL``: SQL (DuckDB) or a named query over a fleet archive."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    from sensemaking.fleet.query import DEFAULT_MAX_ROWS, DEFAULT_MEMORY_MB, NAMED_QUERIES

    named = "\n".join(f"  {q.usage}\n      {q.help}" for q in NAMED_QUERIES.values())
    p = sub.add_parser(
        "query",
        help="ask an archive written by `sensemaking batch`: SQL or a named query",
        description="Answer SQL (DuckDB) over the archive's tables tracks, events, warnings, "
        "metrics "
        "and runs (columns in docs/FLEET.md), e.g.\n"
        '  sensemaking query archive "SELECT situation, count(*) FROM warnings GROUP BY ALL"\n\n'
        "or a named query with its arguments:\n" + named + "\n\nThe SQL is one SELECT (or "
        "EXPLAIN) that reads the archive's tables and nothing else (docs/SECURITY.md). Ctrl-C "
        "stops it. Needs the 'fleet' extra.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "archive", type=Path, help="archive folder (from `sensemaking batch --archive`)"
    )
    p.add_argument("query", help="SQL, or the name of a named query")
    p.add_argument("args", nargs="*", help="arguments of a named query")
    p.add_argument(
        "--format",
        choices=("table", "csv", "json"),
        default="table",
        help="output format (default: an aligned table)",
    )
    p.add_argument(
        "--max-rows",
        type=int,
        default=DEFAULT_MAX_ROWS,
        metavar="N",
        help=f"rows the answer may have (default {DEFAULT_MAX_ROWS}); more is an error",
    )
    p.add_argument(
        "--max-memory",
        type=int,
        default=DEFAULT_MEMORY_MB,
        metavar="MB",
        help=f"memory DuckDB may use for the query, MB (default {DEFAULT_MEMORY_MB})",
    )
    # an interrupted query's DuckDB tasks run on past the interrupt: the CLI ends at once
    p.set_defaults(func=run, exits_at_once=True)


def run(args: argparse.Namespace) -> int:
    from sensemaking.errors import InputError
    from sensemaking.fleet.query import run_query

    for name, value in (("--max-rows", args.max_rows), ("--max-memory", args.max_memory)):
        if value <= 0:
            raise InputError(f"{name} must be a positive integer, got {value}")
    result = run_query(
        args.archive, args.query, args.args, max_rows=args.max_rows, memory_mb=args.max_memory
    )
    sys.stdout.write(result.format(args.format))
    return 0

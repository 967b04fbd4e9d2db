"""``sensemaking query ARCHIVE SQL``: SQL (DuckDB) or a named query over a fleet archive."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    from sensemaking.fleet.query import NAMED_QUERIES

    named = "\n".join(f"  {q.usage}\n      {q.help}" for q in NAMED_QUERIES.values())
    p = sub.add_parser(
        "query",
        help="ask an archive written by `sensemaking batch`: SQL or a named query",
        description="Answer SQL (DuckDB) over the archive's tables tracks, events, warnings, "
        "metrics "
        "and runs (columns in docs/FLEET.md), e.g.\n"
        '  sensemaking query archive "SELECT situation, count(*) FROM warnings GROUP BY ALL"\n\n'
        "or a named query with its arguments:\n" + named + "\n\nNeeds the 'fleet' extra.",
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
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from sensemaking.fleet.query import run_query

    result = run_query(args.archive, args.query, args.args)
    sys.stdout.write(result.format(args.format))
    return 0

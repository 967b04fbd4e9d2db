"""A benchmark run in brief: the overview table ``sensemaking benchmark`` prints and the JSON of
every number it writes. The project's own pages (``docs/BENCHMARKS.md`` with its acceptance
targets, ``docs/PARAMETERS.md``) are rendered outside the package, by
``benchmarks/benchmark_report.py``, from the same run."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sensemaking.benchmark.peers import DISPLAY_NAMES
from sensemaking.benchmark.runner import RunSummary
from sensemaking.io.atomic import atomic_write

__all__ = ["metric", "pct", "count", "overview", "summary_json", "write_json", "UNITS"]

#: alternative names the evaluator may use for a field
_ALIASES: dict[str, tuple[str, ...]] = {
    "FP": ("FP", "CLR_FP"),
    "FN": ("FN", "CLR_FN"),
    "TP": ("TP", "CLR_TP"),
    "MT": ("MT",),
    "PT": ("PT",),
    "ML": ("ML",),
    "Frag": ("Frag",),
    "IDSW": ("IDSW",),
}

#: the units of the JSON's numbers
UNITS: dict[str, str] = {
    "MOTA": "fraction",
    "MOTP": "fraction",
    "IDF1": "fraction",
    "HOTA": "fraction",
    "MT": "count",
    "ML": "count",
    "ms_per_frame": "milliseconds",
}


def metric(m: Mapping[str, float] | None, key: str) -> float:
    """Field ``key`` of a metrics mapping (under any of its names), NaN when absent."""
    if not m:
        return math.nan
    for k in _ALIASES.get(key, (key,)):
        if k in m:
            return float(m[k])
    return math.nan


def pct(x: float, digits: int = 1) -> str:
    """A fraction as a percentage for a table (``–`` for none; no ``-0.0``)."""
    if x is None or math.isnan(x):
        return "–"
    text = f"{100 * x:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def count(x: float) -> str:
    """A count for a table (``–`` for none)."""
    return "–" if x is None or math.isnan(x) else f"{int(round(x))}"


def overview(summary: RunSummary) -> list[str]:
    """A markdown table: per benchmark and tracker, HOTA / MOTA / IDF1 / ID switches."""
    names = [t for t in summary.trackers]
    header = ["Benchmark", *(DISPLAY_NAMES.get(n, n) for n in names)]
    lines = [
        "| " + " | ".join(header) + " |",
        "|" + "|".join(["---"] + ["---:"] * len(names)) + "|",
    ]
    for b in summary.benchmarks:
        cells = []
        for n in names:
            r = b.chosen(n)
            if r is None or r.error is not None or not r.metrics:
                cells.append("–")
                continue
            m = r.metrics
            cells.append(
                f"{pct(metric(m, 'HOTA'))} / {pct(metric(m, 'MOTA'))} / "
                f"{pct(metric(m, 'IDF1'))} / {count(metric(m, 'IDSW'))}"
            )
        lines.append(f"| [{b.spec.name}](#{b.spec.name}) | " + " | ".join(cells) + " |")
    return lines


def summary_json(
    summary: RunSummary,
    extra: Mapping[str, Any] | None = None,
    units: Mapping[str, str] | None = None,
) -> dict[str, Any]:
    """Every number of the run, for machines: the run's JSON, then ``extra`` entries, then
    ``"units"`` (:data:`UNITS` and ``units``)."""
    data = summary.to_json()
    data.update(extra or {})
    data["units"] = {**UNITS, **(units or {})}
    return data


def _clean(x: Any) -> Any:
    if isinstance(x, float) and (math.isnan(x) or math.isinf(x)):
        return None
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_clean(v) for v in x]
    return x


def write_json(summary: RunSummary | Mapping[str, Any], path: str | Path) -> Path:
    """Write :func:`summary_json` of a run (or a ready mapping), NaN as null, atomically."""
    js = Path(path)
    data = summary_json(summary) if isinstance(summary, RunSummary) else summary
    with atomic_write(js) as fh:
        json.dump(_clean(data), fh, indent=1)
        fh.write("\n")
    return js

"""Precision-recall curves of the events that carry a confidence, as inline SVG, and the one
self-contained HTML page ``sensemaking evaluate --explanations --html`` writes.

The points are the rows of :func:`~sensemaking.evaluation.explanations.confidence_table` (the
events at or above each confidence threshold kept): recall on x, precision on y, both 0..1.
Each point carries its exact numbers as ``data-threshold``, ``data-recall`` and
``data-precision``, so the picture can be checked against the printed table. No script, no
external file, no dependency: the page opens offline.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from typing import Any

from sensemaking.evaluation.explanations import (
    EVENT_KINDS,
    IMPLAUSIBLE,
    PLAUSIBLE,
    ExplanationResult,
    explanation_table,
    spread_table,
)

__all__ = ["curve_points", "pr_curve_svg", "confidence_rows_html", "explanations_html"]

#: size of one curve, px, and the margin around its plot area
_W, _H, _M = 360, 260, 40


def curve_points(rows: Sequence[Mapping[str, Any]]) -> list[tuple[float, float, float]]:
    """``(threshold, recall, precision)`` of the rows where both are defined, in the rows'
    order (thresholds rising)."""
    return [
        (float(r["threshold"]), float(r["recall"]), float(r["precision"]))
        for r in rows
        if r.get("recall") is not None and r.get("precision") is not None
    ]


def _xy(recall: float, precision: float) -> tuple[float, float]:
    return _M + recall * (_W - 2 * _M), _H - _M - precision * (_H - 2 * _M)


def pr_curve_svg(rows: Sequence[Mapping[str, Any]], title: str) -> str:
    """An inline ``<svg>`` of the precision-recall curve of ``rows`` (confidence_table rows);
    a text saying so where no row has both a precision and a recall."""
    pts = curve_points(rows)
    esc = html.escape(title)
    parts = [
        f'<svg class="pr-curve" width="{_W}" '
        f'height="{_H}" viewBox="0 0 {_W} {_H}" role="img" aria-label="{esc}">',
        f'<text x="{_W / 2:.0f}" y="16" text-anchor="middle" font-size="13">{esc}</text>',
    ]
    x0, y0 = _xy(0.0, 0.0)
    x1, y1 = _xy(1.0, 1.0)
    parts.append(
        f'<rect x="{x0:.1f}" y="{y1:.1f}" width="{x1 - x0:.1f}" height="{y0 - y1:.1f}" '
        'fill="none" stroke="#888"/>'
    )
    for v in (0.0, 0.5, 1.0):
        gx, _ = _xy(v, 0.0)
        _, gy = _xy(0.0, v)
        parts.append(
            f'<text x="{gx:.1f}" y="{y0 + 14:.1f}" text-anchor="middle" '
            f'font-size="10">{v:g}</text>'
        )
        parts.append(
            f'<text x="{x0 - 4:.1f}" y="{gy + 3:.1f}" text-anchor="end" '
            f'font-size="10">{v:g}</text>'
        )
    parts.append(
        f'<text x="{_W / 2:.0f}" y="{_H - 6}" text-anchor="middle" font-size="11">recall</text>'
    )
    parts.append(
        f'<text x="12" y="{_H / 2:.0f}" text-anchor="middle" font-size="11" '
        f'transform="rotate(-90 12 {_H / 2:.0f})">precision</text>'
    )
    if not pts:
        parts.append(
            f'<text x="{_W / 2:.0f}" y="{_H / 2:.0f}" text-anchor="middle" font-size="11">'
            "no threshold with both precision and recall</text>"
        )
    else:
        line = " ".join(f"{x:.1f},{y:.1f}" for x, y in (_xy(r, p) for _, r, p in pts))
        parts.append(f'<polyline points="{line}" fill="none" stroke="#1f77b4"/>')
        for thr, r, p in pts:
            x, y = _xy(r, p)
            tip = f"confidence >= {thr:g}: precision {100 * p:.1f} %, recall {100 * r:.1f} %"
            parts.append(
                f'<circle class="pr-point" cx="{x:.1f}" cy="{y:.1f}" r="3.5" fill="#1f77b4" '
                f'data-threshold="{thr!r}" data-recall="{r!r}" data-precision="{p!r}">'
                f"<title>{html.escape(tip)}</title></circle>"
            )
        # one label per place: thresholds that keep the same events share a point
        groups: list[list[tuple[float, float, float]]] = []
        for pt in pts:
            if groups and groups[-1][-1][1:] == pt[1:]:
                groups[-1].append(pt)
            else:
                groups.append([pt])
        for g in groups:
            x, y = _xy(g[0][1], g[0][2])
            label = f"{g[0][0]:g}" if len(g) == 1 else f"{g[0][0]:g}-{g[-1][0]:g}"
            parts.append(f'<text x="{x + 5:.1f}" y="{y - 5:.1f}" font-size="9">{label}</text>')
    parts.append("</svg>")
    return "".join(parts)


def confidence_rows_html(rows: Sequence[Mapping[str, Any]]) -> str:
    """The confidence_table rows as an HTML table (percentages with one decimal)."""

    def pct(x: float | None) -> str:
        return "-" if x is None else f"{100 * x:.1f}"

    head = "".join(
        f"<th>{h}</th>"
        for h in ("confidence &gt;=", "n", "plausible", "implausible", "precision %", "recall %")
    )
    body = "".join(
        f"<tr><td>{r['threshold']:.1f}</td><td>{r['n']}</td><td>{r[PLAUSIBLE]}</td>"
        f"<td>{r[IMPLAUSIBLE]}</td><td>{pct(r['precision'])}</td><td>{pct(r['recall'])}</td>"
        "</tr>"
        for r in rows
    )
    return f'<table class="by-confidence"><tr>{head}</tr>{body}</table>'


def explanations_html(
    results: Mapping[str, Sequence[ExplanationResult]], title: str = "Explanation quality"
) -> str:
    """One self-contained HTML page: per benchmark, a precision-recall curve and its table for
    each event or warning kind with ``by_confidence`` rows (those that state a confidence; for a
    warning, recall is the share of the right warnings kept), then the explanation table and
    the per-sequence spread (markdown, as printed)."""
    sections = []
    for bench, seqs in results.items():
        summary = ExplanationResult.combine(seqs).summary()
        blocks = []
        for kind, row in [
            *((k, summary["events"].get(k, {})) for k in EVENT_KINDS),
            *summary["warnings"].items(),
        ]:
            rows = row.get("by_confidence")
            if not rows or not row.get("total"):
                continue
            blocks.append(
                f'<figure class="pr" data-kind="{html.escape(kind)}">'
                f"{pr_curve_svg(rows, f'{bench}: {kind}')}"
                f"<figcaption>{confidence_rows_html(rows)}</figcaption></figure>"
            )
        if not blocks:
            blocks.append("<p>No event or warning with a confidence.</p>")
        sections.append(
            f'<section data-benchmark="{html.escape(bench)}"><h2>{html.escape(bench)}</h2>'
            + "".join(blocks)
            + "</section>"
        )
    tables = explanation_table(dict(results)) + "\n" + spread_table(dict(results))
    style = (
        "body{font-family:sans-serif;margin:1.5em}figure.pr{display:inline-block;"
        "margin:0 1.5em 1.5em 0;vertical-align:top}table.by-confidence{border-collapse:collapse;"
        "font-size:12px}table.by-confidence td,table.by-confidence th{border:1px solid #ccc;"
        "padding:2px 6px;text-align:right}pre{font-size:11px;overflow-x:auto}"
    )
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{style}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>"
        "<p>Precision (plausible of the decidable) and recall of the events kept at or above "
        "each confidence threshold; for a warning, recall is the share of its plausible "
        "warnings kept (docs/EXPLANATIONS.md).</p>"
        + "".join(sections)
        + f"<h2>All events and warnings</h2><pre>{html.escape(tables)}</pre>"
        "</body></html>\n"
    )
